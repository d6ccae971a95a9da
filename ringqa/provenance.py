"""Stamp results and reports with software version, date and inputs (after pylinac's pdf.py)."""

from __future__ import annotations

import datetime as _dt
import hashlib
import platform
from dataclasses import dataclass, field
from pathlib import Path

from ringqa import __version__


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
    """

    software: str
    created_utc: str
    python: str
    inputs: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)

    @classmethod
    def now(cls, inputs=(), settings=None) -> Provenance:
        """Provenance for a run starting now with the given input files and settings."""
        return cls(
            software=f"ringqa {__version__}",
            created_utc=_dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
            python=platform.python_version(),
            inputs={str(p): sha256_of(p) for p in inputs if Path(p).is_file()},
            settings=dict(settings or {}),
        )

    def as_dict(self) -> dict:
        """Plain dict for JSON output."""
        return {
            "software": self.software,
            "created_utc": self.created_utc,
            "python": self.python,
            "inputs": dict(self.inputs),
            "settings": dict(self.settings),
        }
