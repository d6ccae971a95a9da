"""Where ringqa finds its shipped data (applicators, scenes, examples).

In a checkout (or an editable install) the data live in the top-level ``data/`` folder; a wheel
carries the same files in ``ringqa/_data``. :func:`data_dir` hides the difference.
"""

from __future__ import annotations

from pathlib import Path

_PACKAGE_DIR = Path(__file__).resolve().parent


def data_dir() -> Path:
    """Return the folder holding ``applicators/``, ``scenes/`` and ``examples/``."""
    for candidate in (_PACKAGE_DIR / "_data", _PACKAGE_DIR.parent / "data"):
        if (candidate / "applicators").is_dir():
            return candidate
    raise FileNotFoundError(
        "ringqa's data folder is missing: reinstall ringqa (pip install .) from a complete checkout"
    )
