"""ringqa's applicator file format (JSON, millimetres) and the shipped applicators.

Format (``format_version`` 1; full description in ``data/applicators/README.md``)::

    {
      "format": "ringqa-applicator", "format_version": 1, "name": "ring26x60", "units": "mm",
      "metadata": {"diameter_mm": 26, "angle_deg": 60, "sources": [...], "assumptions": [...]},
      "ring_frame": {"centre_mm": [0, 0, 0], "normal": [0, 0, 1], "lateral": [1, 0, 0],
                     "radius_mm": 13.0},
      "channels": [
        {"name": "ring",
         "centreline_mm": [[x, y, z], ...],          # PROXIMAL -> DISTAL (or "centreline_file")
         "lumen": {"kind": "u", "r_b_mm": 1.5, "r_a_mm": 1.4, "flat_mm": 1.5,
                   "flat_towards": "ring_outside", "u_start_mm": 60.0,
                   "source": "Straathof et al. 2024 ..."},
         "s_ref_mm": 142.9,                          # arc length of relative position 0
         "measured_path_mm": [[x, y, z], ...],       # optional, MOST DISTAL FIRST
         "measured_step_mm": 2.5}, ...]
    }

The lumen is a spec in the one vocabulary of :mod:`ringqa.geometry.lumen_spec` (shared with scene
files): ``circular``, ``u`` or ``stepped``, with ``flat_towards`` and ``source``; older files'
``u_shaped`` and ``segments`` are read too. Instead of ``s_ref_mm`` a channel may give
``tip_to_first_dwell_mm`` (s_ref = length - that) or, with a measured path,
``"s_ref_mm": "from_measured_path"`` (s_ref = arc length closest to the path's first point: an
estimate, asked for by name, never guessed).

A measured path's relative positions are read as given: ``measured_relative_mm`` (inline) or a
``relative_position_mm`` column (file), uneven spacing kept; without them, ``measured_step_mm``
numbers the positions 0, step, 2 step, ... ``measured_path_source`` says where the path comes from
(default: "user file <name>").

A FOLDER is accepted too: ``applicator.json`` (as above, where ``centreline_file`` /
``measured_path_file`` name CSV files in the folder), or an ``applicator.json`` without
``channels`` beside ``centreline.csv`` (+ optional ``measured_path.csv``): one channel (``channel``
key, default "ring") with the top-level ``lumen``, ``s_ref_mm`` / ``tip_to_first_dwell_mm``,
``measured_step_mm`` and optional ``ring_frame`` (fitted to the distal 40 mm of the centreline
when absent).

Every problem raises :class:`ApplicatorFileError` naming the file, the field and the fix. An
unknown (misspelt) key is refused with the nearest known one (:data:`CHANNEL_KEYS` and its
siblings are the one list of known keys); inline points are checked as point files are
(:func:`ringqa.io.points.check_points`); a ring radius outside :data:`RING_RADIUS_MM`, a
centreline listed tip first, and a measured path shifted off its channel, listed proximal first
or spaced unlike its declared step are refused (:func:`path_problem`). CSV files read in another
encoding than UTF-8 leave a note in ``metadata["notes"]``. Table: ``docs/validation.md``.
"""

from __future__ import annotations

import difflib
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.errors import InputFileError, RingQAError
from ringqa.geometry import (
    Applicator,
    Centreline,
    Channel,
    GeometryError,
    Lumen,
    RingFrame,
    fit_ring_frame,
)
from ringqa.geometry.lumen_spec import lumen_from_spec, lumen_to_spec
from ringqa.geometry.registration import OUTSIDE_DISTANCE_M, path_placement
from ringqa.geometry.shape_checks import check_channel_shape
from ringqa.io.points import PointSet, PointsFileError, check_points, read_point_set
from ringqa.jsonio import json_text, to_jsonable
from ringqa.outdir import atomic_write_text
from ringqa.paths import data_dir
from ringqa.textio import read_json
from ringqa.units import m_to_mm, mm_to_m

FORMAT = "ringqa-applicator"
FORMAT_VERSION = 1
SHIPPED_DIR = "applicators"
FOLDER_FILE = "applicator.json"

# The keys this reader knows: the ONE list each level is checked against (unknown keys are
# refused with the nearest known one suggested; a misspelt key must not be silently ignored).
#: keys of a channel object
CHANNEL_KEYS = ("name", "centreline_mm", "centreline_file", "lumen", "s_ref_mm",
                "tip_to_first_dwell_mm", "measured_path_mm", "measured_path_file",
                "measured_relative_mm", "measured_step_mm", "measured_path_source",
                "length_mm", "family")  # fmt: skip
#: keys of ``ring_frame``
RING_FRAME_KEYS = ("centre_mm", "normal", "lateral", "radius_mm")
#: top-level keys of an applicator file
TOP_KEYS = ("format", "format_version", "name", "units", "conventions", "metadata",
            "ring_frame", "channels", "family", "dose_points", "simulate_mm")  # fmt: skip
#: top-level keys of a family other than the ring (:mod:`ringqa.geometry.families`) kept in the
#: applicator's metadata: its own dose points ``[{"name", "position_mm"}]`` and the span
#: simulated without a measured path (mm)
FAMILY_METADATA_KEYS = ("dose_points", "simulate_mm")
#: channel keys a folder's applicator.json gives at the top level (one channel beside
#: centreline.csv), and the key naming that channel
FOLDER_CHANNEL_KEYS = ("lumen", "s_ref_mm", "tip_to_first_dwell_mm", "measured_step_mm",
                       "measured_path_source")  # fmt: skip
FOLDER_KEYS = (*TOP_KEYS, "channel", *FOLDER_CHANNEL_KEYS, "lumen_diameter_mm")
#: A ring applicator's radius (mm; the shipped rings are 13-17 mm): outside, another unit.
RING_RADIUS_MM = (5.0, 50.0)
#: The measured positions' median spacing may differ from the declared spacing by this factor
#: (positions off the centreline in a 13 mm ring are spaced up to ~10 % more or less).
SPACING_FACTOR = 1.25
#: A measured path is refused as shifted off its channel when at least this share of its
#: positions lie beyond ``OUTSIDE_DISTANCE_M`` (fewer: the commissioning run flags and leaves out
#: single positions, see :mod:`ringqa.geometry.registration`).
OFF_CHANNEL_SHARE = 0.75


class ApplicatorFileError(InputFileError):
    """An applicator file or folder cannot be read correctly."""


# --------------------------------------------------------------------------------------------
# public API


def shipped_applicators() -> tuple[str, ...]:
    """Names of the applicators shipped in ``data/applicators`` (e.g. ``"ring26x60"``)."""
    try:
        folder = data_dir() / SHIPPED_DIR
    except FileNotFoundError:
        return ()
    return tuple(sorted(p.stem for p in folder.glob("*.json")))


def load_applicator(name_or_path: str | os.PathLike) -> Applicator:
    """Load an applicator by shipped name, from a JSON file, or from a folder.

    Parameters
    ----------
    name_or_path : str or path
        A shipped name (see :func:`shipped_applicators`), a ``.json`` file in this format, or a
        folder (see the module docstring).

    Returns
    -------
    Applicator

    Raises
    ------
    ApplicatorFileError
        Unknown name, missing file, malformed content (names the field and the fix).
    """
    text = os.fspath(name_or_path)
    p = Path(text)
    if p.is_dir():
        return _load_folder(p)
    if p.is_file():
        return _load_json_file(p)
    names = shipped_applicators()
    if text in names:
        return _load_json_file(data_dir() / SHIPPED_DIR / f"{text}.json")
    raise ApplicatorFileError(
        text,
        "no such applicator file, folder or shipped name",
        "give a path to an applicator .json or folder, or one of: " + ", ".join(names),
    )


def applicator_to_dict(app: Applicator, decimals: int | None = None) -> dict[str, Any]:
    """The JSON document (mm) for ``app``; ``decimals`` rounds coordinates (mm)."""

    def num(x: float) -> float | None:
        x = float(x)
        if not math.isfinite(x):
            return None
        return round(x, decimals) if decimals is not None else x

    def pts(a_m) -> list:
        return [[num(v) for v in row] for row in m_to_mm(np.asarray(a_m, dtype=float))]

    channels = []
    for ch in app.channels:
        entry: dict[str, Any] = {
            "name": ch.name,
            "centreline_mm": pts(ch.centreline.points_m),
            "lumen": lumen_to_spec(ch.lumen),
            "s_ref_mm": float(m_to_mm(ch.s_ref_m)),
            "length_mm": float(m_to_mm(ch.length_m)),
        }
        if ch.measured_path_m is not None:
            entry["measured_path_mm"] = pts(ch.measured_path_m)
        if ch.measured_step_m is not None:
            entry["measured_step_mm"] = float(m_to_mm(ch.measured_step_m))
        if ch.measured_relative_m is not None:
            entry["measured_relative_mm"] = [num(v) for v in m_to_mm(ch.measured_relative_m)]
        if ch.measured_source:
            entry["measured_path_source"] = ch.measured_source
        if ch.family:
            entry["family"] = ch.family
        channels.append(entry)
    family = {} if app.family == "ring" else {"family": app.family}
    meta = dict(app.metadata)
    family_meta = {k: meta.pop(k) for k in FAMILY_METADATA_KEYS if k in meta and family}
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "name": app.name,
        **family,
        **to_jsonable(family_meta),
        "units": "mm",
        "conventions": {
            "centreline": "points in mm, ordered proximal (channel entry) -> distal (lumen tip)",
            "s_ref_mm": "arc length from the proximal end to the source centre at relative "
            "position 0 (most distal dwell); relative position p sits at s_ref_mm - p",
            "measured_path_mm": "source-centre positions, most distal first (p = 0, step, ... or "
            "measured_relative_mm as given)",
            "lumen": "kind circular | u | stepped (ringqa.geometry.lumen_spec); flat_mm from the "
            "centreline, facing flat_towards (bend_outside, or fixed in the ring frame: "
            "ring_outside, cranial, caudal); at or beyond r_b_mm the flat does not cut the "
            "circle; source = where the dimensions come from, or 'assumed'",
            "frame": "ring plane normal points cranially, lateral to the patient's left",
        },
        "metadata": to_jsonable(meta),
        "ring_frame": {
            "centre_mm": [float(v) for v in m_to_mm(app.ring_centre_m)],
            "normal": [float(v) for v in app.ring_normal],
            "lateral": [float(v) for v in app.ring_lateral],
            "radius_mm": float(m_to_mm(app.ring_radius_m)),
        },
        "channels": channels,
    }


def save_applicator(app: Applicator, path: str | os.PathLike, decimals: int | None = None) -> Path:
    """Write ``app`` to ``path`` (JSON, mm) atomically (:func:`ringqa.outdir.atomic_write_text`).

    Parameters
    ----------
    app : Applicator
    path : str or path
        Target ``.json`` file.
    decimals : int, optional
        Round coordinates to this many decimals of a millimetre (None: full precision, so a
        reload gives the identical applicator).

    Returns
    -------
    Path
        The file written.
    """
    if not isinstance(app, Applicator):
        raise RingQAError("save_applicator: app must be a ringqa.geometry.Applicator")
    target = Path(path)
    if target.suffix.lower() != ".json":
        raise ApplicatorFileError(target, "applicator files are JSON", "use a .json file name")
    text = json_text(applicator_to_dict(app, decimals), indent=1) + "\n"
    return atomic_write_text(target, text)


# --------------------------------------------------------------------------------------------
# reading


class _Reader:
    """Field access with errors that name the file and the field."""

    def __init__(self, path: Path, base: Path | None = None):
        self.path = path
        self.base = base if base is not None else path.parent
        self.notes: list[str] = []  # for the user (e.g. a CSV read as Latin-1)

    def known_keys(self, d, known: tuple[str, ...], where: str, also: str = "") -> None:
        """Refuse a key of ``d`` not in ``known``, suggesting the nearest known key."""
        if not isinstance(d, dict):
            return
        for key in d:
            if key in known:
                continue
            field = f"{where}.{key}" if where else str(key)
            near = difflib.get_close_matches(str(key), known, n=1, cutoff=0.6)
            hint = f"did you mean {near[0]!r}?" if near else "remove or rename it."
            if "diameter" in str(key):
                hint += " The lumen is given by its radius: lumen.r_b_mm = diameter / 2."
            raise self.fail(
                field, f"unknown key{also}", f"{hint} Known keys here: {', '.join(known)}"
            )

    def fail(self, field: str, problem: str, fix: str = "") -> ApplicatorFileError:
        return ApplicatorFileError(self.path, f"{field}: {problem}", fix)

    def get(self, d: dict, key: str, where: str, default=..., kind=None):
        if not isinstance(d, dict):
            raise self.fail(where, "expected a JSON object", "see data/applicators/README.md")
        if key not in d or d[key] is None:
            if default is ...:
                raise self.fail(
                    f"{where}.{key}" if where else key,
                    "missing",
                    "add it (see data/applicators/README.md)",
                )
            return default
        return d[key]

    def number(self, d: dict, key: str, where: str, default=..., positive=False) -> float | None:
        v = self.get(d, key, where, default)
        if v is None:
            return None
        field = f"{where}.{key}" if where else key
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(field, f"expected a number (mm), got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.fail(field, "must be finite")
        if positive and v <= 0:
            raise self.fail(field, f"must be > 0, got {v:g}")
        return v

    def numbers(self, v, field: str, allow_null=False) -> np.ndarray:
        if not isinstance(v, list) or not v:
            raise self.fail(field, "expected a non-empty list of numbers")
        out = []
        for i, x in enumerate(v):
            if x is None and allow_null:
                out.append(math.nan)
                continue
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise self.fail(f"{field}[{i}]", f"expected a finite number, got {x!r}")
            out.append(float(x))
        return np.array(out)

    def points(self, v, field: str) -> np.ndarray:
        if not isinstance(v, list) or not v:
            raise self.fail(field, "expected a list of [x, y, z] points in mm")
        rows = []
        for i, row in enumerate(v):
            if not isinstance(row, list) or len(row) != 3:
                raise self.fail(f"{field}[{i}]", f"expected [x, y, z] in mm, got {row!r}")
            rows.append(self.numbers(row, f"{field}[{i}]"))
        return np.array(rows)

    def vector(self, d: dict, key: str, where: str) -> np.ndarray:
        v = self.get(d, key, where)
        arr = self.numbers(v, f"{where}.{key}")
        if arr.shape != (3,):
            raise self.fail(f"{where}.{key}", "expected 3 numbers")
        return arr


def _load_json_file(path: Path) -> Applicator:
    doc = read_json(path, error=ApplicatorFileError)  # strict: duplicate keys, depth, encoding
    return _from_dict(doc, _Reader(path))


def _load_folder(folder: Path) -> Applicator:
    spec = folder / FOLDER_FILE
    if not spec.is_file():
        raise ApplicatorFileError(
            folder,
            f"no {FOLDER_FILE} in the folder",
            f"add {FOLDER_FILE} with the lumen, s_ref_mm and ring frame beside centreline.csv "
            "(see data/applicators/README.md)",
        )
    doc = read_json(spec, error=ApplicatorFileError)
    rd = _Reader(spec, folder)
    if isinstance(doc, dict) and "channels" not in doc:
        rd.known_keys(doc, FOLDER_KEYS, "")
        cl_file = folder / "centreline.csv"
        if not cl_file.is_file():
            raise ApplicatorFileError(
                folder, "no centreline.csv and no 'channels' in applicator.json",
                "add centreline.csv (x_mm,y_mm,z_mm, proximal -> distal)",
            )  # fmt: skip
        family = doc.get("family", "ring")
        ch: dict[str, Any] = {
            "name": doc.get("channel", "ring" if family == "ring" else "channel"),
            "centreline_file": "centreline.csv",
        }
        for key in FOLDER_CHANNEL_KEYS:
            if key in doc:
                ch[key] = doc[key]
        if "lumen_diameter_mm" in doc:
            if "lumen" in doc:
                raise rd.fail(
                    "lumen_diameter_mm",
                    "given beside lumen",
                    "give one of them (lumen_diameter_mm: a circular lumen)",
                )
            dia = rd.number(doc, "lumen_diameter_mm", "", positive=True)
            ch["lumen"] = {"kind": "circular", "r_b_mm": dia / 2.0,
                           "source": f"{FOLDER_FILE} lumen_diameter_mm"}  # fmt: skip
        if (folder / "measured_path.csv").is_file():
            ch["measured_path_file"] = "measured_path.csv"
        doc = {k: v for k, v in doc.items() if k in TOP_KEYS} | {"channels": [ch]}
    return _from_dict(doc, rd)


def _from_dict(doc, rd: _Reader) -> Applicator:
    if not isinstance(doc, dict):
        raise rd.fail("(top level)", "expected a JSON object", "see data/applicators/README.md")
    rd.known_keys(doc, TOP_KEYS, "")
    fmt = doc.get("format", FORMAT)
    if fmt != FORMAT:
        raise rd.fail("format", f"{fmt!r} is not {FORMAT!r}", "is this an applicator file?")
    version = doc.get("format_version", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise rd.fail(
            "format_version", f"{version!r} is not supported (this ringqa reads {FORMAT_VERSION})",
            "upgrade ringqa or re-export the file",
        )  # fmt: skip
    units = doc.get("units", "mm")
    if units != "mm":
        raise rd.fail("units", f"{units!r}: applicator files are in millimetres", 'use "mm"')
    name = rd.get(doc, "name", "", default=rd.path.stem)
    if not isinstance(name, str) or not name.strip():
        raise rd.fail("name", "expected a non-empty string")
    raw_channels = rd.get(doc, "channels", "")
    if not isinstance(raw_channels, list) or not raw_channels:
        raise rd.fail("channels", "expected a non-empty list of channel objects")
    for i, c in enumerate(raw_channels):
        name_i = c.get("name") if isinstance(c, dict) else None
        rd.known_keys(c, CHANNEL_KEYS, f"channels[{i}]",
                      f" in channel {name_i!r}" if isinstance(name_i, str) else "")  # fmt: skip
    metadata = doc.get("metadata", {})
    if not isinstance(metadata, dict):
        raise rd.fail("metadata", "expected a JSON object")
    family = _family(doc, rd)
    metadata = {**metadata, **{k: doc[k] for k in FAMILY_METADATA_KEYS if k in doc}}
    frame = doc.get("ring_frame")
    if family != "ring":
        return _family_applicator(doc, rd, name, family, raw_channels, metadata)
    if frame is None:
        # a lumen fixed in the ring frame is read once the frame is fitted to the channels
        plain = [_without_fixed_flat(c) for c in raw_channels]
        channels = tuple(_channel(c, f"channels[{i}]", rd) for i, c in enumerate(plain))
        fit = _fit_frame(channels, rd)
        centre, normal, lateral, radius = fit.centre_m, fit.normal, fit.lateral, fit.radius_m
        channels = tuple(
            ch if c is p else _channel(c, f"channels[{i}]", rd, (centre, normal))
            for i, (c, p, ch) in enumerate(zip(raw_channels, plain, channels, strict=True))
        )
    else:
        rd.known_keys(frame, RING_FRAME_KEYS, "ring_frame")
        centre = mm_to_m(rd.vector(frame, "centre_mm", "ring_frame"))
        normal = rd.vector(frame, "normal", "ring_frame")
        lateral = rd.vector(frame, "lateral", "ring_frame")
        radius = mm_to_m(rd.number(frame, "radius_mm", "ring_frame", positive=True))
        _check_radius(m_to_mm(radius), "ring_frame.radius_mm", rd)
        for key, v in (("normal", normal), ("lateral", lateral)):
            n = float(np.linalg.norm(v))
            if n == 0:
                raise rd.fail(f"ring_frame.{key}", "zero vector", "give a unit vector")
        normal = normal / np.linalg.norm(normal)
        lateral = lateral / np.linalg.norm(lateral)
        channels = tuple(
            _channel(c, f"channels[{i}]", rd, (centre, normal)) for i, c in enumerate(raw_channels)
        )
    if rd.notes:
        notes = metadata.get("notes", [])
        notes = list(notes) if isinstance(notes, list | tuple) else [str(notes)]
        metadata = {**metadata, "notes": list(dict.fromkeys([*notes, *rd.notes]))}
    try:
        return Applicator(
            name=name,
            channels=channels,
            ring_centre_m=centre,
            ring_normal=normal,
            ring_lateral=lateral,
            ring_radius_m=float(radius),
            metadata=metadata,
        )
    except GeometryError as exc:
        raise rd.fail("ring_frame/channels", str(exc)) from None


def _family(doc: dict, rd: _Reader) -> str:
    """The applicator's family (``"family"``, default ``"ring"``), checked against the
    registered families."""
    from ringqa.geometry.families import FAMILIES

    family = doc.get("family", "ring")
    if family not in FAMILIES:
        raise rd.fail("family", f"{family!r} is not an applicator family",
                      "choose one of: " + ", ".join(sorted(FAMILIES)))  # fmt: skip
    for k in FAMILY_METADATA_KEYS:
        if k in doc and family == "ring":
            raise rd.fail(
                k,
                "is for applicators of another family than the ring",
                'declare the family (e.g. "family": "free-form") or leave it out',
            )
    return family


def _family_applicator(doc, rd: _Reader, name: str, family: str, raw_channels, metadata):
    """An applicator of a family other than the ring: its channels (each of the applicator's
    family unless it names its own), its frame as given in ``ring_frame`` or fitted by
    :func:`ringqa.geometry.frame.fit_frame`, its own dose points checked."""
    from ringqa.geometry.families import family_named
    from ringqa.geometry.families.free_form import user_points

    frame = doc.get("ring_frame")
    given: dict[str, Any] = {}
    if frame is not None:
        rd.known_keys(frame, RING_FRAME_KEYS, "ring_frame")
        given = {
            "ring_centre_m": mm_to_m(rd.vector(frame, "centre_mm", "ring_frame")),
            "ring_normal": _unit_or_fail(rd, rd.vector(frame, "normal", "ring_frame"), "normal"),
            "ring_lateral": _unit_or_fail(rd, rd.vector(frame, "lateral", "ring_frame"),
                                          "lateral"),
            "ring_radius_m": mm_to_m(rd.number(frame, "radius_mm", "ring_frame", positive=True)),
        }  # fmt: skip
    centre_normal = (given["ring_centre_m"], given["ring_normal"]) if given else None
    channels = []
    for i, c in enumerate(raw_channels):
        if isinstance(c, dict) and "family" in c:
            try:
                family_named(c["family"])
            except GeometryError as exc:
                raise rd.fail(f"channels[{i}].family", str(exc)) from None
        c = c if not isinstance(c, dict) or "family" in c else {**c, "family": family}
        channels.append(_channel(c, f"channels[{i}]", rd, centre_normal, family=family))
    try:
        app = Applicator(name=name, channels=tuple(channels), metadata=metadata, family=family,
                         **given)  # fmt: skip
        user_points(app)
    except GeometryError as exc:
        raise rd.fail("ring_frame/channels/dose_points", str(exc)) from None
    return app


def _unit_or_fail(rd: _Reader, v: np.ndarray, key: str) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n == 0:
        raise rd.fail(f"ring_frame.{key}", "zero vector", "give a unit vector")
    return v / n


def _without_fixed_flat(c):
    """``c`` with a flat fixed in the ring frame read as following the bend (for fitting the
    frame first); ``c`` itself when it has none."""
    lum = c.get("lumen") if isinstance(c, dict) else None
    if not isinstance(lum, dict) or lum.get("flat_towards", "bend_outside") == "bend_outside":
        return c
    return {**c, "lumen": {**lum, "flat_towards": "bend_outside"}}


def _fit_frame(channels, rd: _Reader) -> RingFrame:
    """Ring frame from the first channel: :func:`ringqa.geometry.fit_ring_frame` of its distal
    40 mm (the proximal entry lies caudally; lateral = patient left), refused unless a circle."""
    ch = channels[0]
    cl = ch.centreline
    s = np.linspace(max(0.0, cl.length_m - 0.04), cl.length_m, 81)
    frame = fit_ring_frame(cl.position(s), caudal_point_m=cl.position(0.0))
    if frame.rms_m > 0.5e-3:
        if _is_circle(cl, proximal=True):
            raise _tip_first_error(rd, f"channels[0] ({ch.name})")
        raise rd.fail(
            "ring_frame", f"missing, and the distal 40 mm of channel {ch.name!r} is not a circle "
            f"(rms {frame.rms_m * 1e3:.2f} mm)",
            "give ring_frame {centre_mm, normal, lateral, radius_mm}",
        )  # fmt: skip
    _check_radius(m_to_mm(frame.radius_m), f"ring_frame (fitted to channel {ch.name!r})", rd)
    return frame


def _check_radius(radius_mm: float, field: str, rd: _Reader) -> None:
    lo, hi = RING_RADIUS_MM
    if not lo <= radius_mm <= hi:
        raise rd.fail(
            field, f"ring radius {radius_mm:.4g} mm is implausible (ring applicators: {lo:g}-"
            f"{hi:g} mm; the shipped rings 13-17 mm)",
            "give millimetres (centimetres: multiply by 10) and the RADIUS, not the diameter",
        )  # fmt: skip


#: arc length (m) of a centreline end tested for being the ring's circle
_END_M = 40.0e-3


def _is_circle(cl: Centreline, proximal: bool) -> bool:
    """Whether the proximal (else distal) 40 mm of ``cl`` are a ring-sized circular arc."""
    if cl.length_m < 2 * _END_M:
        return False
    a, b = (0.0, _END_M) if proximal else (cl.length_m - _END_M, cl.length_m)
    try:
        frame = fit_ring_frame(cl.position(np.linspace(a, b, 81)))
    except (GeometryError, np.linalg.LinAlgError, ValueError):
        return False
    lo, hi = RING_RADIUS_MM
    return frame.rms_m < 0.5e-3 and lo <= m_to_mm(frame.radius_m) <= hi


def _tip_first_error(rd: _Reader, where: str) -> ApplicatorFileError:
    return rd.fail(
        f"{where}.centreline", "runs from the tip to the entry: its FIRST 40 mm are the ring's "
        "circle and its last 40 mm are not",
        "list the centreline points PROXIMAL (channel entry) first and the lumen tip last "
        "(reverse the rows)",
    )  # fmt: skip


def _inline_points(rd: _Reader, v, field: str, kind: str) -> np.ndarray:
    """Points (mm) given in the applicator file, checked as a point file's are."""
    pts = rd.points(v, field)
    try:
        check_points(rd.path, pts, None, [f"{field}[{i}]" for i in range(len(pts))], kind)
    except PointsFileError as exc:
        raise ApplicatorFileError(rd.path, f"{field}: {exc.problem}", exc.fix) from None
    return pts


def _read_csv_points(rd: _Reader, field: str, name, kind: str) -> np.ndarray:
    return _read_csv_point_set(rd, field, name, kind).points_m


def _read_csv_point_set(rd: _Reader, field: str, name, kind: str) -> PointSet:
    if not isinstance(name, str):
        raise rd.fail(field, f"expected a file name, got {name!r}")
    p = (rd.base / name).resolve()
    pset = read_point_set(p, kind=kind)  # raises PointsFileError naming the file
    rd.notes.extend(pset.notes)
    return pset


def _channel(c, where: str, rd: _Reader, ring_frame=None, family: str = "ring") -> Channel:
    if not isinstance(c, dict):
        raise rd.fail(where, "expected a channel object")
    name = rd.get(c, "name", where)
    if not isinstance(name, str) or not name.strip():
        raise rd.fail(f"{where}.name", "expected a non-empty string")
    where = f"{where} ({name})"
    if "centreline_mm" in c:
        pts_m = mm_to_m(_inline_points(rd, c["centreline_mm"], f"{where}.centreline_mm",
                                       "centreline"))  # fmt: skip
    elif "centreline_file" in c:
        pts_m = _read_csv_points(rd, f"{where}.centreline_file", c["centreline_file"], "centreline")
    else:
        raise rd.fail(
            f"{where}.centreline_mm", "missing", "give centreline_mm points or centreline_file"
        )
    try:
        cl = Centreline.from_points(pts_m)
    except GeometryError as exc:
        raise rd.fail(f"{where}.centreline_mm", str(exc)) from None
    if family == "ring" and _is_circle(cl, proximal=True) and not _is_circle(cl, proximal=False):
        raise _tip_first_error(rd, where)
    lumen = _lumen(rd.get(c, "lumen", where), f"{where}.lumen", rd, ring_frame)
    path_m, rel_m, origin = _measured_path(c, where, rd)
    step = rd.number(c, "measured_step_mm", where, default=None, positive=True)
    step_m = None if step is None else mm_to_m(step)
    if path_m is not None:
        step_m = _path_spacing(path_m, rel_m, step_m, where, rd)
    s_ref = _s_ref(c, where, rd, cl, path_m)
    try:
        channel = Channel(
            name=name,
            centreline=cl,
            lumen=lumen,
            s_ref_m=float(s_ref),
            measured_path_m=path_m,
            measured_step_m=step_m,
            measured_relative_m=rel_m,
            measured_source=origin,
            family=str(c.get("family", "")),
        )
    except GeometryError as exc:
        raise rd.fail(where, str(exc)) from None
    _check_length(c, where, rd, cl)
    try:
        check_channel_shape(channel, f"{where}.centreline")
    except GeometryError as exc:
        raise rd.fail(where + ".centreline", str(exc).split(": ", 1)[1]) from None
    if path_m is not None:
        problem = path_problem(channel, path_m, rel_m, step)
        if problem:
            raise rd.fail(f"{where}.measured_path", *problem)
    return channel


#: ``length_mm`` (informative: the centreline's length) may differ from the centreline's length
#: by this much (mm) before the file is refused as inconsistent.
LENGTH_TOL_MM = 1.0


def _check_length(c: dict, where: str, rd: _Reader, cl: Centreline) -> None:
    """``length_mm`` (optional) must be a number equal to the centreline's length."""
    if "length_mm" not in c:
        return
    given = rd.number(c, "length_mm", where, positive=True)
    actual = m_to_mm(cl.length_m)
    if abs(given - actual) > LENGTH_TOL_MM:
        raise rd.fail(
            f"{where}.length_mm",
            f"{given:g} mm, but the centreline is {actual:.2f} mm long",
            "correct length_mm or the centreline points (or leave length_mm out: it is the "
            "centreline's length)",
        )


def path_problem(channel: Channel, path_m, rel_m=None, step_mm=None) -> tuple[str, str] | None:
    """``(problem, fix)`` when a measured path (m, most distal first) is grossly wrong for its
    channel, else None: shifted off the channel (farther from the centreline than
    :data:`~ringqa.geometry.registration.OUTSIDE_DISTANCE_M`), listed proximal first, or spaced
    unlike its declared step / relative positions (by more than :data:`SPACING_FACTOR`); shifted
    means at least :data:`OFF_CHANNEL_SHARE` of the positions off the channel. The
    per-position checks are :func:`ringqa.geometry.registration.check_reference_path`'s."""
    path = np.asarray(path_m, dtype=float)
    place = path_placement(path, channel)
    if place.n_off >= OFF_CHANNEL_SHARE * len(path):
        return (
            f"the positions lie a median {m_to_mm(place.median_offset_m):.1f} mm from the "
            f"centreline of channel {channel.name!r}, {place.n_off} of {len(path)} farther than "
            f"{m_to_mm(OUTSIDE_DISTANCE_M):g} mm (a source centre lies within a lumen radius of "
            "it): the path as a whole is not along the channel",
            "give the path in the same coordinates as the centreline (is it shifted, or in "
            "another frame or unit?)",
        )
    if place.direction > 0:
        return (
            "the positions run from the entry towards the tip (arc length rises by "
            f"{m_to_mm(place.median_step_m):.2f} mm per position), but a measured path lists "
            "source positions MOST DISTAL FIRST",
            "reverse the order of the rows (most distal position, relative position 0, first)",
        )
    if len(path) >= 2:
        gaps = np.linalg.norm(np.diff(path, axis=0), axis=1)
        if rel_m is not None:
            declared = np.diff(np.asarray(rel_m, dtype=float))
            what = "the relative positions step by"
        elif step_mm is not None:
            declared = np.full(gaps.size, mm_to_m(step_mm))
            what = "measured_step_mm says"
        else:
            return None
        ratio = float(np.median(gaps / declared))
        if not 1 / SPACING_FACTOR <= ratio <= SPACING_FACTOR:
            return (
                f"consecutive positions are {m_to_mm(float(np.median(gaps))):.3g} mm apart "
                f"(median) but {what} {m_to_mm(float(np.median(declared))):.3g} mm",
                "correct measured_step_mm (or the relative positions) to the path's spacing, "
                "or check that every position is listed once",
            )
    return None


#: ``s_ref_mm`` value asking for s_ref at the measured path's first position (an estimate).
S_REF_FROM_PATH = "from_measured_path"


def _measured_path(c: dict, where: str, rd: _Reader):
    """The measured path (m), its relative positions as given (m, or None) and its provenance."""
    origin = rd.get(c, "measured_path_source", where, default=None)
    if origin is not None and not (isinstance(origin, str) and origin.strip()):
        raise rd.fail(
            f"{where}.measured_path_source", "expected a text",
            'say where the path comes from, e.g. "vendor measurement, 2024-03-01"',
        )  # fmt: skip
    rel_mm = None
    if c.get("measured_path_mm") is not None:
        path_m = mm_to_m(_inline_points(rd, c["measured_path_mm"], f"{where}.measured_path_mm",
                                        "path"))  # fmt: skip
        if c.get("measured_relative_mm") is not None:
            rel_mm = rd.numbers(c["measured_relative_mm"], f"{where}.measured_relative_mm")
        default_origin = f"user file {rd.path.name}"
    elif c.get("measured_path_file") is not None:
        name = c["measured_path_file"]
        pset = _read_csv_point_set(rd, f"{where}.measured_path_file", name, "path")
        path_m, rel_mm = pset.points_m, pset.relative_position_mm
        default_origin = f"user file {Path(pset.path).name}"
    else:
        return None, None, ""
    rel_m = None
    if rel_mm is not None:
        rel_mm = np.asarray(rel_mm, dtype=float).reshape(-1)
        field = f"{where}.measured_relative_mm"
        if rel_mm.size != len(path_m):
            raise rd.fail(
                field, f"{rel_mm.size} relative positions for {len(path_m)} measured positions",
                "give one relative position (mm) per measured position",
            )  # fmt: skip
        if np.any(np.diff(rel_mm) <= 0):
            k = int(np.flatnonzero(np.diff(rel_mm) <= 0)[0])
            raise rd.fail(
                field, f"relative positions {rel_mm[k]:g} and {rel_mm[k + 1]:g} mm do not "
                "increase (duplicated or out of order)",
                "list the positions most distal (0) first, each relative position once",
            )  # fmt: skip
        rel_m = mm_to_m(rel_mm)
    return path_m, rel_m, (origin or default_origin).strip()


def _path_spacing(path_m, rel_m, step_m, where: str, rd: _Reader) -> float | None:
    """The measured path's step (m): as given, or from evenly spaced relative positions; None for
    uneven ones. Refuses a path with neither, and a step that contradicts the positions."""
    if rel_m is None:
        if step_m is None:
            raise rd.fail(
                f"{where}.measured_step_mm", "missing",
                "give the measured path's spacing (mm), or a relative_position_mm column "
                "(measured_relative_mm) with each position's relative position",
            )  # fmt: skip
        return step_m
    gaps = np.diff(rel_m)
    even = gaps.size > 0 and np.allclose(gaps, gaps[0], rtol=0.0, atol=1e-6)
    if step_m is not None and not (even and abs(gaps[0] - step_m) <= 1e-6):
        raise rd.fail(
            f"{where}.measured_step_mm",
            f"{m_to_mm(step_m):g} mm contradicts the relative positions given "
            f"({', '.join(f'{m_to_mm(x):g}' for x in rel_m[:4])}, ... mm)",
            "drop measured_step_mm (the relative positions are used as given) or correct it",
        )
    return float(gaps[0]) if even else None


def _s_ref(c: dict, where: str, rd: _Reader, cl, path_m) -> float:
    """s_ref (m): ``s_ref_mm``, ``length - tip_to_first_dwell_mm``, or, when asked for with
    ``"s_ref_mm": "from_measured_path"``, the arc length closest to the path's first position."""
    value = c.get("s_ref_mm")
    if value == S_REF_FROM_PATH:
        if path_m is None:
            raise rd.fail(
                f"{where}.s_ref_mm", f"{S_REF_FROM_PATH!r} needs a measured path",
                "give s_ref_mm in mm",
            )  # fmt: skip
        s_arr, d_arr = cl.closest(path_m[:1])
        if d_arr[0] > 2e-3:
            raise rd.fail(
                f"{where}.s_ref_mm", f"{S_REF_FROM_PATH!r}, but the measured path's first point "
                f"is {d_arr[0] * 1e3:.1f} mm from the centreline", "give s_ref_mm in mm",
            )  # fmt: skip
        return float(s_arr[0])
    if value is not None:
        return mm_to_m(rd.number(c, "s_ref_mm", where))
    if c.get("tip_to_first_dwell_mm") is not None:
        return cl.length_m - mm_to_m(rd.number(c, "tip_to_first_dwell_mm", where))
    raise rd.fail(
        f"{where}.s_ref_mm", "missing",
        "give s_ref_mm (arc length of relative position 0, mm) or tip_to_first_dwell_mm; "
        f'"s_ref_mm": "{S_REF_FROM_PATH}" takes the arc length nearest the measured path\'s '
        "first position (an estimate: every along-channel deviation depends on it)",
    )  # fmt: skip


def _lumen(d, where: str, rd: _Reader, ring_frame=None) -> Lumen:
    """The channel's lumen from its spec (:mod:`ringqa.geometry.lumen_spec`: one vocabulary for
    applicator and scene files); a flat fixed in the applicator's frame needs ``ring_frame``."""
    if not isinstance(d, dict):
        raise rd.fail(where, "expected a JSON object", "see data/applicators/README.md")
    try:
        return lumen_from_spec(d, where, ring_frame)
    except GeometryError as exc:
        raise ApplicatorFileError(rd.path, str(exc)) from None
