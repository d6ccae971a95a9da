"""Find and read scene files and apply ``--set`` dotted-key overrides; nothing is validated here.

A scene name resolves to ``data/scenes/<name>.toml`` (:func:`shipped_scenes` lists them); the
file is read as plain TOML, and :func:`apply_overrides` sets dotted keys in a copy of it, parsing
string values as TOML values (:func:`parse_value`).
"""

from __future__ import annotations

import copy
import datetime as _dt
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ringqa.errors import SceneError
from ringqa.textio import read_toml


def read_scene_dict(path: str | Path) -> dict:
    """Read a scene TOML file into a plain dict (no validation).

    Raises
    ------
    SceneError
        The file is missing or is not valid TOML (with the parser's line and column).
    """
    p = Path(path)
    if not p.is_file():
        raise SceneError(f"{p}: scene file not found (give the path to a .toml scene file)")
    return read_toml(p, error=_scene_error)  # ringqa.textio: UTF-16 read, errors named


def _scene_error(path: Path, problem: str, fix: str) -> SceneError:
    return SceneError(f"{path}: {problem} ({fix})")


def parse_value(text: str) -> Any:
    """A ``--set`` value: a TOML value if it parses as one, else the plain string."""
    if not isinstance(text, str):
        return text
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):  # nested too deeply: kept as text
        return text


def parse_set_args(items: list[str] | None) -> dict[str, Any]:
    """``["solver.increment_mm=0.5", ...]`` -> ``{"solver.increment_mm": 0.5, ...}``."""
    out: dict[str, Any] = {}
    for item in items or ():
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise SceneError(f"--set {item!r}: expected KEY=VALUE, e.g. solver.increment_mm=0.5")
        out[key.strip()] = parse_value(value.strip())
    return out


def plain_copy(value):
    """A deep copy of plain scene data (dicts, lists, tuples of TOML values; numpy arrays).

    What :func:`copy.deepcopy` gives for such data, without its memo bookkeeping: a scene's
    inline centreline is thousands of floats, and ``deepcopy`` of one took ~10 ms (0.1 s of the
    warm example's run, measured). Immutable values (str, int, float, bool, dates) are shared;
    anything else goes to ``deepcopy``.
    """
    if isinstance(value, dict):
        return {k: plain_copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [v if type(v) in _ATOMIC else plain_copy(v) for v in value]
    if isinstance(value, tuple):
        return tuple(plain_copy(v) for v in value)
    if type(value) in _ATOMIC:
        return value
    return copy.deepcopy(value)


#: immutable TOML values: shared by :func:`plain_copy`
_ATOMIC = frozenset({str, int, float, bool, type(None), _dt.datetime, _dt.date, _dt.time})


def apply_overrides(data: Mapping, overrides: Mapping[str, Any] | None, origin: str = "") -> dict:
    """A deep copy of ``data`` with dotted-key overrides applied (values parsed from strings)."""
    out = plain_copy(dict(data))
    for dotted, value in (overrides or {}).items():
        parts = [p for p in str(dotted).split(".") if p]
        if not parts:
            raise SceneError(f"{origin}--set {dotted!r}: empty key")
        node = out
        for i, part in enumerate(parts[:-1]):
            child = node.get(part)
            if child is None:
                child = node[part] = {}
            if not isinstance(child, dict):
                where = ".".join(parts[: i + 1])
                raise SceneError(
                    f"{origin}--set {dotted}: {where} is a value, not a table (set {where} "
                    f"itself, e.g. {where} = {{thin = 3.0, thick = 10.0}})"
                )
            node = child
        node[parts[-1]] = parse_value(value)
    return out


def resolve_scene_path(ref: str | Path) -> Path:
    p = Path(ref)
    if p.is_file() or p.suffix == ".toml" or "/" in str(ref):
        return p
    from ringqa.paths import data_dir

    try:
        shipped = data_dir() / "scenes" / f"{ref}.toml"
    except FileNotFoundError:
        return p
    return shipped if shipped.is_file() else p


def shipped_scenes() -> tuple[str, ...]:
    """Names of the scenes shipped in ``data/scenes`` (load them with :func:`load_scene`)."""
    from ringqa.paths import data_dir

    return tuple(sorted(p.stem for p in (data_dir() / "scenes").glob("*.toml")))
