"""Read a scene dict's keys through the key registry and build errors that name file and key.

Every key's type, range and default come from :mod:`ringqa.simulation.scene_keys` (described
there once). :data:`SCHEMA` is the same registry as ``section -> key -> (types, default, check)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ringqa.errors import SceneError
from ringqa.simulation.scene_keys import (
    CHANNEL_KINDS,
    KEYS,
    LUMEN_KINDS,
    NUM,
    SECTIONS,
    key,
    section_keys,
    value_problem,
)

__all__ = ["CHANNEL_KINDS", "LUMEN_KINDS", "SCHEMA", "Checker"]

#: ``section -> key name -> (accepted types, default (user units), check)`` (from the registry;
#: the custom instrument section's keys are under ``"section"``)
SCHEMA: dict[str, dict[str, tuple[Any, Any, Any]]] = {
    s: {k.name: (k.types, k.default, k.check) for k in KEYS if k.section == s}
    for s in (*SECTIONS, "section")
}


class Checker:
    """Reads a scene dict's keys through the registry; ``origin`` prefixes every error."""

    def __init__(self, data: dict, origin: str) -> None:
        self.data = data
        self.origin = origin  # "path: " or ""

    def fail(self, dotted: str, problem: str, fix: str) -> SceneError:
        """The error for key ``dotted``: ``origin dotted: problem (fix)``."""
        return SceneError(f"{self.origin}{dotted}: {problem} ({fix})")

    def section(self, name: str) -> dict:
        """The table ``[name]`` (empty when absent); unknown keys are refused."""
        sec = self.data.get(name, {})
        if not isinstance(sec, dict):
            raise self.fail(name, "must be a table", f"write it as [{name}] with keys below it")
        allowed = [k.name for k in section_keys(name)]
        unknown = sorted(set(sec) - set(allowed))
        if unknown:
            raise self.fail(
                f"{name}.{unknown[0]}",
                "unknown key",
                f"keys allowed in [{name}]: {', '.join(allowed)}",
            )
        return sec

    def value(self, section: str, name: str, default: Any = ..., sec: dict | None = None):
        """The user-unit value of ``section.name`` (checked), or its default."""
        k = key(section, name)
        src = self.data if not section else (sec if sec is not None else self.section(section))
        if name not in src:
            return k.default if default is ... else default
        return self.check(k.dotted, src[name], k.types, k.check)

    def check(self, dotted: str, val, types, check):
        """``val`` checked against ``types`` and ``check`` (see :class:`scene_keys.Key`)."""
        problem = value_problem(val, tuple(types), check)
        if problem:
            raise self.fail(dotted, f"got {val!r}", problem)
        if isinstance(val, list) and check in ("positive", "nonneg"):
            for i, v in enumerate(val):
                self.check(f"{dotted}[{i}]", v, NUM, check)
        return float(val) if isinstance(val, int) and float in types and int not in types else val

    def numbers(self, dotted: str, val, ndim: int = 1, positive: bool = False) -> np.ndarray:
        """A list (ndim 1) or list of [x, y, z] (ndim 2) of finite numbers as an array."""
        try:
            arr = np.asarray(val, dtype=float)
        except (TypeError, ValueError):
            raise self.fail(dotted, "not a list of numbers", "write e.g. [1.0, 2.0, 3.0]") from None
        if arr.ndim != ndim or (ndim == 2 and arr.shape[1] != 3) or arr.size == 0:
            shape = "[[x, y, z], ...]" if ndim == 2 else "[a, b, ...]"
            raise self.fail(dotted, f"wrong shape {arr.shape}", f"write it as {shape}")
        if not np.all(np.isfinite(arr)):
            raise self.fail(dotted, "contains non-finite values", "use finite numbers")
        if positive and np.any(arr <= 0):
            raise self.fail(dotted, "contains values <= 0", "all values must be > 0")
        return arr
