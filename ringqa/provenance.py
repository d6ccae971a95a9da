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
import hashlib
import platform
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from ringqa import __version__

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


def sha256_of(path: str | Path) -> str:
    """SHA-256 hex digest of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


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
        Input file path -> SHA-256 digest.
    settings : dict
        Settings that change the result (scene keys, source, prescription...).
    dependencies : dict
        Distribution name -> installed version (:data:`DEPENDENCIES`).
    data : dict
        Data file path (TG-43 source data used) -> SHA-256 digest.
    """

    software: str
    created_utc: str
    python: str
    inputs: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    dependencies: dict = field(default_factory=dict)
    data: dict = field(default_factory=dict)

    @classmethod
    def now(cls, inputs=(), settings=None, data=()) -> Provenance:
        """Provenance for a run starting now with the given input files, settings and data
        files (e.g. :func:`tg43_data_files` of the source used)."""
        return cls(
            software=f"ringqa {__version__}",
            created_utc=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            python=platform.python_version(),
            inputs={str(p): sha256_of(p) for p in inputs if Path(p).is_file()},
            settings=dict(settings or {}),
            dependencies=dependency_versions(),
            data={str(p): sha256_of(p) for p in data if Path(p).is_file()},
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
