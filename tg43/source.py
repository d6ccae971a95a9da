"""TG-43 source data: reading, checking and holding one source's consensus tables.

A source folder holds (all lengths in cm, as in the AAPM/ESTRO HEBD consensus sheets):

- ``meta.json``: ``Lambda_cGy_per_h_per_U``, ``L_cm`` (active length), ``r0_cm``, ``theta0_deg``,
  ``reference``, ``origin`` (optional ``r_min_cm``: the smallest valid distance, see below);
- ``gL.csv``: header ``r_cm,gL[,flag_extrap]``, radial dose function of the line source;
- ``F_r_theta.csv``: header ``theta_deg\\r_cm,<r values>``, one row per polar angle (degrees,
  0 = towards the source TIP, 180 = towards the cable);
- optional ``F_r_theta_flags.csv`` (same grid, 1 = interpolated/extrapolated value in the sheet);
- optional ``QA_along_away_cGy_h-1_U-1.csv``: header ``z_cm\\y_cm,<y values>``, the consensus
  along-away dose-rate table (z along the axis, +z towards the tip; y away from it).

Shipped sources are looked up by name (see :data:`SOURCE_FOLDERS`) in ``tg43/_data/sources``
(a wheel) or ``<checkout>/data/sources``; any folder in the same format can be given by path.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tg43.errors import TG43Error

_PACKAGE_DIR = Path(__file__).resolve().parent

#: Shipped source names -> folder under ``data/sources``.
SOURCE_FOLDERS: dict[str, str] = {
    "flexisource": "flexisource",
    "mhdr-v2": "mhdr-v2",
    "gammamed-plus": "gammamed-plus",
    "vs2000": "vs2000",
    "m-19": "m-19",
}

META_FILE = "meta.json"
GL_FILE = "gL.csv"
F_FILE = "F_r_theta.csv"
F_FLAGS_FILE = "F_r_theta_flags.csv"
QA_FILE = "QA_along_away_cGy_h-1_U-1.csv"


def sources_dir() -> Path:
    """Return the folder holding the shipped source folders.

    ``tg43/_data/sources`` (inside a wheel) is tried first, then ``<checkout>/data/sources``.

    Raises
    ------
    TG43Error
        If neither folder exists (an incomplete installation).
    """
    for candidate in (_PACKAGE_DIR / "_data" / "sources", _PACKAGE_DIR.parent / "data" / "sources"):
        if candidate.is_dir():
            return candidate
    raise TG43Error(
        "tg43 source data folder is missing (looked in tg43/_data/sources and data/sources): "
        "reinstall from a complete checkout (pip install .)"
    )


def known_sources() -> tuple[str, ...]:
    """Names accepted by :func:`load_source` (besides folder paths)."""
    return tuple(SOURCE_FOLDERS)


@dataclass(frozen=True, eq=False)
class Source:
    """One TG-43 source: consensus tables and geometry (read-only).

    Attributes
    ----------
    name : str
        Short name (``flexisource``) or the folder name for a source given by path.
    description : str
        The source's full name from ``meta.json``.
    folder : pathlib.Path
        Folder the data were read from.
    dose_rate_constant : float
        Lambda in cGy h^-1 U^-1.
    active_length_cm : float
        Active length L used in the line-source geometry function G_L, cm.
    r0_cm, theta0_deg : float
        Reference point (1 cm, 90 deg).
    r_min_cm : float
        Smallest valid distance from the source centre, cm: nearer points count as inside the
        source and are refused. Default L/2 (the sphere around the active core; a point exactly at
        r = L/2 is accepted unless it is on the source axis).
    gl_r_cm : ndarray, shape (n_g,)
        Radii of the radial dose function table, cm, strictly increasing.
    gl : ndarray, shape (n_g,)
        g_L(r), dimensionless.
    f_r_cm : ndarray, shape (n_r,)
        Radii of the anisotropy table, cm, strictly increasing.
    f_theta_deg : ndarray, shape (n_theta,)
        Polar angles of the anisotropy table, degrees, strictly increasing from 0 to 180.
    f : ndarray, shape (n_theta, n_r)
        F(r, theta), dimensionless.
    f_flags : ndarray of bool, shape (n_theta, n_r) or None
        True where the consensus sheet marks F as interpolated/extrapolated.
    qa_z_cm, qa_y_cm : ndarray or None
        Grid of the consensus along-away QA table, cm (z towards the tip, y away from the axis).
    qa_dose_rate : ndarray, shape (n_z, n_y), or None
        Consensus dose rate per unit air-kerma strength, cGy h^-1 U^-1.
    reference, origin : str
        Citation and provenance of the numbers.
    """

    name: str
    description: str
    folder: Path
    dose_rate_constant: float
    active_length_cm: float
    r0_cm: float
    theta0_deg: float
    r_min_cm: float
    gl_r_cm: np.ndarray
    gl: np.ndarray
    f_r_cm: np.ndarray
    f_theta_deg: np.ndarray
    f: np.ndarray
    f_flags: np.ndarray | None = None
    qa_z_cm: np.ndarray | None = None
    qa_y_cm: np.ndarray | None = None
    qa_dose_rate: np.ndarray | None = None
    reference: str = ""
    origin: str = ""
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("gl_r_cm", "gl", "f_r_cm", "f_theta_deg", "f", "f_flags", "qa_z_cm",
                     "qa_y_cm", "qa_dose_rate"):  # fmt: skip
            value = getattr(self, name)
            if value is not None:
                value.setflags(write=False)

    @property
    def has_qa_table(self) -> bool:
        """Whether the consensus along-away QA table is shipped with the source."""
        return self.qa_dose_rate is not None

    def __repr__(self) -> str:
        return (
            f"Source({self.name!r}, Lambda={self.dose_rate_constant} cGy/h/U, "
            f"L={self.active_length_cm} cm, folder={str(self.folder)!r})"
        )


def load_source(name_or_path: str | Path) -> Source:
    """Load a TG-43 source by shipped name or from a folder.

    Parameters
    ----------
    name_or_path : str or pathlib.Path
        One of :func:`known_sources` (``flexisource``, ``mhdr-v2``, ``gammamed-plus``, ``vs2000``,
        ``m-19``; case-insensitive), or the path of a folder in the same format.

    Returns
    -------
    Source
        Frozen source object (cached per folder).

    Raises
    ------
    TG43Error
        Unknown name (the message lists the known ones), or a missing/malformed data file (the
        message names the file and the problem).
    """
    if isinstance(name_or_path, Path) or (
        isinstance(name_or_path, str) and ("/" in name_or_path or "\\" in name_or_path)
    ):
        folder = Path(name_or_path).expanduser()
        if not folder.is_dir():
            raise TG43Error(
                f"source folder {folder} does not exist (give a folder holding meta.json, gL.csv "
                f"and F_r_theta.csv, or one of the names {', '.join(known_sources())})"
            )
        name = folder.resolve().name
    elif isinstance(name_or_path, str):
        key = name_or_path.strip().lower()
        if key not in SOURCE_FOLDERS:
            folder = Path(name_or_path)
            if folder.is_dir():
                return load_source(folder.resolve())
            raise TG43Error(
                f"unknown source {name_or_path!r}: use one of {', '.join(known_sources())} "
                "or the path of a folder with the same files"
            )
        folder = sources_dir() / SOURCE_FOLDERS[key]
        name = key
    else:
        raise TG43Error(
            f"source must be a name or a folder path, got {type(name_or_path).__name__} "
            f"(use one of {', '.join(known_sources())})"
        )
    folder = folder.resolve()
    cache_key = (name, str(folder))
    if cache_key not in _SOURCE_CACHE:
        _SOURCE_CACHE[cache_key] = _read_source(folder, name)
    return _SOURCE_CACHE[cache_key]


_SOURCE_CACHE: dict[tuple[str, str], Source] = {}


# --------------------------------------------------------------------------------------------
# reading and checking


def _read_source(folder: Path, name: str) -> Source:
    meta = _read_meta(folder / META_FILE)
    gl_r, gl = _read_gl(folder / GL_FILE)
    f_theta, f_r, f = _read_table(folder / F_FILE, "theta_deg\\r_cm", "theta_deg", "r_cm")
    _check_increasing(folder / F_FILE, "theta_deg (first column)", f_theta)
    if abs(f_theta[0]) > 1e-9 or abs(f_theta[-1] - 180.0) > 1e-9:
        raise TG43Error(
            f"{folder / F_FILE}: theta_deg must run from 0 to 180 degrees "
            f"(found {f_theta[0]} .. {f_theta[-1]}); complete the table"
        )
    _check_increasing(folder / F_FILE, "r_cm (header row)", f_r)
    if np.any(f < 0):
        raise TG43Error(f"{folder / F_FILE}: negative F values (check the table)")
    flags = None
    if (folder / F_FLAGS_FILE).is_file():
        ft, fr, fl = _read_table(folder / F_FLAGS_FILE, "theta_deg\\r_cm", "theta_deg", "r_cm")
        if (
            ft.shape != f_theta.shape
            or fr.shape != f_r.shape
            or not (np.allclose(ft, f_theta) and np.allclose(fr, f_r))
        ):
            raise TG43Error(
                f"{folder / F_FLAGS_FILE}: grid differs from {F_FILE} (use the same r and theta)"
            )
        flags = fl != 0
    qa_z = qa_y = qa = None
    if (folder / QA_FILE).is_file():
        qa_z, qa_y, qa = _read_table(folder / QA_FILE, "z_cm\\y_cm", "z_cm", "y_cm")
        for label, grid in (("z_cm (first column)", qa_z), ("y_cm (header row)", qa_y)):
            d = np.diff(grid)
            if not (np.all(d > 0) or np.all(d < 0)):
                raise TG43Error(
                    f"{folder / QA_FILE}: {label} is not strictly monotonic (sort the table)"
                )
    length = meta["L_cm"]
    r_min = meta.get("r_min_cm", 0.5 * length)
    if not (math.isfinite(r_min) and r_min >= 0.5 * length):
        raise TG43Error(
            f"{folder / META_FILE}: r_min_cm = {r_min} must be >= L_cm/2 = {0.5 * length} "
            "(points nearer the centre may lie inside the active core)"
        )
    return Source(
        name=name,
        description=str(meta.get("source", name)),
        folder=folder,
        dose_rate_constant=meta["Lambda_cGy_per_h_per_U"],
        active_length_cm=length,
        r0_cm=meta["r0_cm"],
        theta0_deg=meta["theta0_deg"],
        r_min_cm=float(r_min),
        gl_r_cm=gl_r,
        gl=gl,
        f_r_cm=f_r,
        f_theta_deg=f_theta,
        f=f,
        f_flags=flags,
        qa_z_cm=qa_z,
        qa_y_cm=qa_y,
        qa_dose_rate=qa,
        reference=str(meta.get("reference", "")),
        origin=str(meta.get("origin", "")),
    )


def _read_meta(path: Path) -> dict:
    if not path.is_file():
        raise TG43Error(f"{path}: missing (each source folder needs meta.json with Lambda and L)")
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise TG43Error(f"{path}: not valid JSON ({exc}); fix the file") from None
    if not isinstance(meta, dict):
        raise TG43Error(f"{path}: must hold a JSON object")
    defaults = {"r0_cm": 1.0, "theta0_deg": 90.0}
    for key in ("Lambda_cGy_per_h_per_U", "L_cm", "r0_cm", "theta0_deg", "r_min_cm"):
        if key not in meta:
            if key in defaults:
                meta[key] = defaults[key]
                continue
            if key == "r_min_cm":
                continue
            raise TG43Error(f"{path}: missing key {key!r} (add it, a number)")
        value = meta[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise TG43Error(f"{path}: {key!r} must be a number, got {value!r}")
        meta[key] = float(value)
        if not math.isfinite(meta[key]):
            raise TG43Error(f"{path}: {key!r} must be finite, got {value!r}")
    for key in ("Lambda_cGy_per_h_per_U", "L_cm", "r0_cm"):
        if meta[key] <= 0:
            raise TG43Error(f"{path}: {key!r} must be > 0, got {meta[key]}")
    if abs(meta["theta0_deg"] - 90.0) > 1e-12:
        raise TG43Error(f"{path}: theta0_deg must be 90 (TG-43 reference angle)")
    return meta


def _read_rows(path: Path) -> list[list[str]]:
    if not path.is_file():
        raise TG43Error(f"{path}: missing (a source folder needs {GL_FILE} and {F_FILE})")
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            rows = [row for row in csv.reader(fh) if any(cell.strip() for cell in row)]
    except UnicodeDecodeError:
        raise TG43Error(f"{path}: not a UTF-8 text CSV file") from None
    if not rows:
        raise TG43Error(f"{path}: empty file")
    return rows


def _number(path: Path, text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise TG43Error(
            f"{path}: {where}: {text.strip()!r} is not a number (fill in the missing value)"
        ) from None
    if not math.isfinite(value):
        raise TG43Error(f"{path}: {where}: value {text.strip()!r} is not finite")
    return value


def _read_gl(path: Path) -> tuple[np.ndarray, np.ndarray]:
    rows = _read_rows(path)
    header = [h.strip() for h in rows[0]]
    if header[:2] != ["r_cm", "gL"]:
        raise TG43Error(
            f"{path}: header must start with 'r_cm,gL', found {','.join(header)!r} "
            "(first column r in cm, second g_L)"
        )
    r, g = [], []
    for i, row in enumerate(rows[1:], start=2):
        if len(row) < 2:
            raise TG43Error(f"{path}: line {i} has {len(row)} value(s), expected r_cm and gL")
        r.append(_number(path, row[0], f"line {i}, r_cm"))
        g.append(_number(path, row[1], f"line {i}, gL"))
    r_arr, g_arr = np.array(r), np.array(g)
    if r_arr.size < 2:
        raise TG43Error(f"{path}: needs at least two radii")
    _check_increasing(path, "r_cm", r_arr)
    if r_arr[0] < 0 or np.any(g_arr <= 0):
        raise TG43Error(f"{path}: radii must be >= 0 and g_L > 0 (check the table)")
    return r_arr, g_arr


def _read_table(
    path: Path, corner: str, row_label: str, col_label: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a 2D table: header ``corner,<col values>``, rows ``<row value>,<values>``."""
    rows = _read_rows(path)
    header = rows[0]
    if header[0].strip() != corner:
        raise TG43Error(
            f"{path}: first header cell must be {corner!r} ({row_label} down the first column, "
            f"{col_label} along the header), found {header[0].strip()!r}"
        )
    cols = np.array([_number(path, c, f"header, {col_label}") for c in header[1:]])
    if cols.size < 2:
        raise TG43Error(f"{path}: needs at least two {col_label} values in the header")
    row_vals, data = [], []
    for i, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise TG43Error(
                f"{path}: line {i} has {len(row)} cells, header has {len(header)} "
                "(fill in the missing values)"
            )
        row_vals.append(_number(path, row[0], f"line {i}, {row_label}"))
        data.append([_number(path, c, f"line {i}, column {j + 2}") for j, c in enumerate(row[1:])])
    if len(row_vals) < 2:
        raise TG43Error(f"{path}: needs at least two rows")
    return np.array(row_vals), cols, np.array(data)


def _check_increasing(path: Path, label: str, grid: np.ndarray) -> None:
    if not np.all(np.diff(grid) > 0):
        raise TG43Error(f"{path}: {label} values must be strictly increasing (sort the table)")
