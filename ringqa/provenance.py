"""Stamp results and reports with software version, date and inputs (after pylinac's pdf.py).

A :class:`Provenance` records the software and Python versions, the versions of the libraries
the numbers depend on (:data:`DEPENDENCIES`, through :mod:`importlib.metadata`), the SHA-256 of
every input file and of the TG-43 data files used (:func:`tg43_data_files`), and the settings.
The pinned versions of a validated clinical environment are in ``constraints/clinical.txt``
(README, "Installing a validated environment").
"""

from __future__ import annotations

import datetime as _dt
import functools
import platform
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from ringqa import __version__
from ringqa.outdir import sha256_file

#: the distributions whose versions are recorded (those the results depend on)
DEPENDENCIES = (
    "numpy",
    "scipy",
    "numba",
    "pandas",
    "pydicom",
    "matplotlib",
    "h5py",
    "reportlab",
    "plotly",
)
#: the files of a TG-43 source folder that enter the dose (the QA table only checks the engine)
TG43_DATA_FILES = ("meta.json", "gL.csv", "F_r_theta.csv", "F_r_theta_flags.csv")


def dependency_versions(names=DEPENDENCIES) -> dict[str, str]:
    """Installed version of each distribution in ``names`` (those not installed are left out)."""
    return dict(_versions(tuple(names)))


@functools.lru_cache(maxsize=8)
def _versions(names: tuple[str, ...]) -> tuple[tuple[str, str], ...]:
    """The versions, read once per process (each ``metadata.version`` parses the package's
    METADATA file: ~10 ms for the list, five times per commissioning run)."""
    out = []
    for name in names:
        try:
            out.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            continue
    return tuple(out)


def tg43_data_files(folder: str | Path) -> list[Path]:
    """The data files of a TG-43 source folder that exist (:data:`TG43_DATA_FILES`)."""
    return [Path(folder) / n for n in TG43_DATA_FILES if (Path(folder) / n).is_file()]


#: how a file shipped with ringqa (its data folder, or tg43's inside a wheel) is named in outputs
PACKAGE_PREFIX = "ringqa:data/"


def _package_roots() -> list[Path]:
    """The folders of ringqa's shipped data: ``data/`` of a checkout or ``ringqa/_data`` and
    ``tg43/_data`` of a wheel (each holds what ``data/`` holds)."""
    from ringqa.paths import data_dir

    here = Path(__file__).resolve().parent
    roots = [here.parent / "tg43" / "_data"]
    try:
        roots.insert(0, data_dir().resolve())
    except FileNotFoundError:
        pass
    return roots


def display_path(path: str | Path, base: str | Path | None = None) -> str:
    """How a file is named in an output (results.json, CSV, report text): never an install path.

    A shipped file is ``ringqa:data/<path inside data/>`` (``ringqa:data/examples/...``, the same
    from a checkout or a wheel); a file inside ``base`` (the input's folder) is its path
    relative to it; anything else is named as given.

    Parameters
    ----------
    path : str or Path
        The file (or folder).
    base : str or Path, optional
        The input's folder.

    Returns
    -------
    str
        POSIX-style name.
    """
    p = Path(path)
    try:
        full = p.resolve()
    except OSError:
        return str(path)
    for root in _package_roots():
        if full == root or root in full.parents:
            return PACKAGE_PREFIX + full.relative_to(root).as_posix()
    if base is not None:
        try:
            b = Path(base).resolve()
        except OSError:
            b = None
        if b is not None and (full == b or b in full.parents):
            return full.relative_to(b).as_posix() if full != b else "."
    return str(path)


def relative_paths(obj, base: str | Path | None = None):
    """``obj`` (JSON-like: dicts, lists, strings, numbers) with every string that is the absolute
    path of an existing file or folder named by :func:`display_path` (no install path in an
    output); everything else as it was."""
    if isinstance(obj, dict):
        return {k: relative_paths(v, base) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [relative_paths(v, base) for v in obj]
    if isinstance(obj, str) and Path(obj).is_absolute() and "\n" not in obj:
        try:
            exists = Path(obj).exists()
        except (OSError, ValueError):
            exists = False
        return display_path(obj, base) if exists else obj
    return obj


def input_folder(path: str | Path) -> Path:
    """The folder an input's own files are named relative to: the folder of an input file,
    or an input folder itself."""
    p = Path(path)
    return p if p.is_dir() else p.parent


#: SHA-256 hex digest of a file's bytes: the one helper, :func:`ringqa.outdir.sha256_file` (the
#: output folder's marker uses it; defined there so that ``import ringqa.outdir`` stays free of
#: ``importlib.metadata``, tests/cli/test_lazy_imports.py)
sha256_of = sha256_file


@dataclass(frozen=True)
class Provenance:
    """Who made a result, when, and from what.

    Attributes
    ----------
    software : str
        ``"ringqa <version>"``.
    created_utc : str
        ISO 8601 time stamp (UTC) of the run.
    python : str
        Python version.
    inputs : dict
        Input file -> SHA-256 digest (file names by :func:`display_path`: relative to the
        input's folder, ``ringqa:data/...`` for shipped files).
    settings : dict
        Settings that change the result (scene keys, source, prescription...).
    dependencies : dict
        Distribution name -> installed version (:data:`DEPENDENCIES`).
    data : dict
        Data file (TG-43 source data used; ``ringqa:data/sources/...`` for shipped data) ->
        SHA-256 digest.
    """

    software: str
    created_utc: str
    python: str
    inputs: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    dependencies: dict = field(default_factory=dict)
    data: dict = field(default_factory=dict)

    @classmethod
    def now(cls, inputs=(), settings=None, data=(), base=None) -> Provenance:
        """Provenance for a run starting now with the given input files, settings and data
        files (e.g. :func:`tg43_data_files` of the source used); files are named by
        :func:`display_path` relative to ``base`` (default: the first input's folder)."""
        inputs = [p for p in inputs if Path(p).is_file()]
        if base is None and inputs:
            base = input_folder(inputs[0])
        return cls(
            software=f"ringqa {__version__}",
            created_utc=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            python=platform.python_version(),
            inputs={display_path(p, base): sha256_of(p) for p in inputs},
            settings=dict(settings or {}),
            dependencies=dependency_versions(),
            data={display_path(p, base): sha256_of(p) for p in data if Path(p).is_file()},
        )

    def as_dict(self) -> dict:
        """Plain dict for JSON output."""
        return {
            "software": self.software,
            "created_utc": self.created_utc,
            "python": self.python,
            "inputs": dict(self.inputs),
            "settings": dict(self.settings),
            "dependencies": dict(self.dependencies),
            "data": dict(self.data),
        }
