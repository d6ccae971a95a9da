"""The clinic configuration: what a site changes, in a TOML file (read with :mod:`tomllib`).

Where the settings of ``ringqa commission`` come from, lowest to highest precedence:

1. the built-in default (:data:`KEYS`);
2. the user configuration ``config.toml`` in the platform's configuration folder
   (``platformdirs.user_config_dir("ringqa")``; the environment variable ``RINGQA_CONFIG``
   names another file, or none when it is empty);
3. the file given with ``--config FILE``;
4. a command-line option (``--prescription-gy 8``, ``--set solver.increment_mm=0.5``, ...).

A configuration file has the tables ``[tolerances]``, ``[plan]``, ``[dose_points]``,
``[simulation]``, ``[scene]`` (dotted scene keys, as ``--set`` takes them) and ``[report]``
(the fields the signing physicist fills in: :class:`ringqa.report.fields.ReportFields`). The
``recommended.toml`` written by ``ringqa accuracy`` (a scene file) is accepted as is: its
numerical settings (flexible sections' element lengths, increment or time step, tolerance,
stabilisation) become scene overrides. See docs/config.md for every key.

:func:`effective_config` merges the layers and records where each value came from
(:attr:`EffectiveConfig.origins`); :meth:`EffectiveConfig.settings` builds the checked
:class:`~ringqa.pipeline.settings.CommissionSettings` (which carries the origin map into the
result: ``results.json`` ``settings_origin``), :meth:`EffectiveConfig.report_fields` the
report's fields. A bad file is refused with one line naming the file, the key and the fix.
"""

from __future__ import annotations

import dataclasses
import difflib
import logging
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ringqa.errors import RingQAError
from ringqa.pipeline.settings import DEFAULT_ORIGIN, SETTINGS, CommissionSettings
from ringqa.pipeline.settings import Setting as ConfigKey
from ringqa.plan import DosePointSpec
from ringqa.simulation.scene_keys import KEYS as SCENE_KEYS
from ringqa.textio import read_toml

if TYPE_CHECKING:  # imported where used: ringqa.report's package loads reportlab and pandas
    from ringqa.report.fields import ReportFields

log = logging.getLogger(__name__)

#: every configuration key outside ``[scene]``, in the order of docs/config.md: the one settings
#: table (:data:`ringqa.pipeline.settings.SETTINGS`: name, unit, range, default, help, config
#: key, command-line option, CommissionSettings field, results.json key)
KEYS: tuple[ConfigKey, ...] = SETTINGS

#: environment variable naming the user configuration file ("" = none)
ENV_VAR = "RINGQA_CONFIG"
#: origin of a built-in default
DEFAULT = DEFAULT_ORIGIN
#: origin of a command-line option
COMMAND_LINE = "command line"


class ConfigError(RingQAError):
    """A configuration file is unreadable or holds an unknown key or a bad value."""


_BY_KEY = {k.key: k for k in KEYS}
TABLES = ("tolerances", "plan", "dose_points", "simulation", "scene", "report", "calibration")
_SCENE_DOTTED = {k.dotted for k in SCENE_KEYS}
#: scene keys whose value is a table keyed by names (``element_length_mm = {thin = 1.5}``)
_SCENE_TABLE_KEYS = {"discretisation.element_length_mm"}
#: numerical settings taken from a ``ringqa accuracy`` recommended.toml
RECOMMENDED_SOLVER_KEYS = ("increment_mm", "time_step_s", "tol", "stabilisation", "max_iter")


def user_config_path() -> Path | None:
    """The user configuration file: ``$RINGQA_CONFIG`` (empty: none), else ``config.toml`` in
    ``platformdirs.user_config_dir("ringqa")``. None when there is none."""
    env = os.environ.get(ENV_VAR)
    if env is not None:
        return Path(env) if env.strip() else None
    from platformdirs import user_config_dir

    return Path(user_config_dir("ringqa")) / "config.toml"


def _nearest(name: str, known) -> str:
    match = difflib.get_close_matches(name, list(known), n=1, cutoff=0.5)
    return f"did you mean {match[0]}?" if match else "known keys: see docs/config.md"


def _config_error(path: Path, problem: str, fix: str) -> ConfigError:
    return ConfigError(f"{path}: {problem} ({fix})")


def read_config_file(path: str | Path) -> dict[str, Any]:
    """Read and check one configuration file: ``{dotted key: value}`` (scene keys as
    ``scene.<dotted scene key>``).

    Raises
    ------
    ConfigError
        Missing file, bad TOML, unknown key (with the nearest known key) or a value of the wrong
        type or out of range (with the allowed range).
    """
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"{p}: configuration file not found (give the path of a .toml file)")
    data = read_toml(p, error=_config_error)  # ringqa.textio: encodings, errors named
    if _is_scene_file(data):
        taken = recommended_overrides(data)
        log.warning(
            "%s: a scene file (ringqa accuracy's recommended.toml): only its numerical settings "
            "are taken (%s); not taken: %s (the applicator, cable and physics come from the "
            "input and the settings; site scene settings go under [scene] in a configuration)",
            p,
            ", ".join(taken) or "none",
            ", ".join(_not_taken(data)) or "nothing",
        )
        return {f"scene.{k}": v for k, v in taken.items()}
    scene_like = [t for t in data if t not in TABLES and t in _SCENE_TABLES]
    if scene_like and not set(TABLES) & set(data):
        tables = ", ".join(f"[{t}]" for t in scene_like)
        raise ConfigError(
            f"{p}: {tables}: scene settings in a configuration file that is not a complete scene "
            f"file (no [channel] and [instrument]); they would not be used (put them under "
            f"[scene], e.g. [scene.{scene_like[0]}], or give ringqa accuracy's recommended.toml)"
        )
    out: dict[str, Any] = {}
    for table, body in data.items():
        if table not in TABLES:
            hint = (
                f"scene settings go under [scene]: [scene.{table}]"
                if table in _SCENE_TABLES
                else _nearest(table, TABLES)
            )
            raise ConfigError(f"{p}: unknown key '{table}' ({hint}; tables: {', '.join(TABLES)})")
        if not isinstance(body, dict):
            raise ConfigError(f"{p}: '{table}' must be a table ([{table}])")
        if table == "scene":
            for dotted, value in _flatten_scene(p, body).items():
                out[f"scene.{dotted}"] = value
            continue
        for name, value in body.items():
            dotted = f"{table}.{name}"
            spec = _BY_KEY.get(dotted)
            if spec is None:
                raise ConfigError(f"{p}: unknown key '{dotted}' ({_nearest(dotted, _BY_KEY)})")
            problem = spec.problem(value)
            if problem:
                raise ConfigError(f"{p}: {dotted} = {value!r}: {problem}")
            out[dotted] = float(value) if spec.kind == "number" else value
    return out


#: the top-level tables of a scene file
_SCENE_TABLES = frozenset(k.dotted.split(".")[0] for k in SCENE_KEYS)


def _is_scene_file(data: Mapping) -> bool:
    """A complete scene file (``recommended.toml``) rather than a configuration: it has the
    ``[channel]`` and ``[instrument]`` tables a scene needs, and no configuration table. (A
    file with only some scene tables, ``[solver]`` and ``[contact]``, is not one: refused, so
    that its friction values are never dropped without a word.)"""
    return {"channel", "instrument"} <= set(data) and not (set(TABLES) & set(data))


def _not_taken(data: Mapping) -> list[str]:
    """The tables and keys of a scene file that :func:`recommended_overrides` does not take."""
    left = []
    for table, body in data.items():
        if table == "solver" and isinstance(body, Mapping):
            left += [f"solver.{k}" for k in body if k not in RECOMMENDED_SOLVER_KEYS]
        elif table == "discretisation" and isinstance(body, Mapping):
            left += [f"discretisation.{k}" for k in body if k != "element_length_mm"]
        elif table == "instrument":
            left.append("instrument (but its sections' element lengths)")
        else:
            left.append(str(table))
    return left


def recommended_overrides(data: Mapping) -> dict[str, Any]:
    """The numerical settings of a scene file (``ringqa accuracy``'s ``recommended.toml``) as
    dotted scene overrides: every flexible section's element length, and the solver's
    increment (quasi-static) or time step (dynamic), tolerance, stabilisation, iterations."""
    out: dict[str, Any] = {}
    sections = (data.get("instrument") or {}).get("sections") or []
    for sec in sections:
        if isinstance(sec, dict) and not sec.get("rigid") and "element_length_mm" in sec:
            out[f"discretisation.element_length_mm.{sec['name']}"] = sec["element_length_mm"]
    disc = data.get("discretisation") or {}
    if not sections and "element_length_mm" in disc:
        out["discretisation.element_length_mm"] = disc["element_length_mm"]
    solver = data.get("solver") or {}
    for name in RECOMMENDED_SOLVER_KEYS:
        if name in solver:
            out[f"solver.{name}"] = solver[name]
    return out


def _flatten_scene(p: Path, body: Mapping, prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for name, value in body.items():
        dotted = f"{prefix}{name}"
        is_key = dotted in _SCENE_DOTTED
        under_table = any(dotted.startswith(t + ".") for t in _SCENE_TABLE_KEYS)
        if is_key or under_table:
            spec = next((k for k in SCENE_KEYS if k.dotted == dotted), None)
            problem = None
            if spec is not None and not isinstance(value, dict | list):
                problem = spec.problem(value)
            if problem:
                raise ConfigError(f"{p}: scene.{dotted} = {value!r}: {problem}")
            out[dotted] = value
        elif isinstance(value, dict) and any(k.startswith(dotted + ".") for k in _SCENE_DOTTED):
            out.update(_flatten_scene(p, value, dotted + "."))
        else:
            raise ConfigError(
                f"{p}: unknown key 'scene.{dotted}' ({_nearest(dotted, _SCENE_DOTTED)}; scene "
                "keys are those of ringqa simulate's scene files, see data/scenes/README.md)"
            )
    return out


@dataclass(frozen=True)
class EffectiveConfig:
    """The merged settings and where each came from.

    Attributes
    ----------
    values : dict
        Dotted key -> value for every key of :data:`KEYS`, plus ``scene.<dotted>`` for each
        scene override.
    origins : dict
        Dotted key -> ``"default"``, ``"user config <path>"``, ``"--config <path>"`` or
        ``"command line"``.
    extra : dict
        Command-line settings that have no configuration key (``centreline_correction``,
        ``require_measured``), passed to :class:`CommissionSettings` as they are.
    """

    values: dict[str, Any]
    origins: dict[str, str]
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def scene_overrides(self) -> dict[str, Any]:
        """The dotted scene overrides (``solver.increment_mm``: value)."""
        return {k[6:]: v for k, v in self.values.items() if k.startswith("scene.")}

    def settings(self) -> CommissionSettings:
        """The checked :class:`CommissionSettings` (carrying :attr:`origins`).

        Raises
        ------
        ConfigError
            A combination the settings refuse, named with the file the values came from.
        """
        v = self.values
        # a field with one key in the settings table takes its value as it is; the fields of
        # several keys (dose points, the tolerance pair, the stem) are put together below
        rows = [k for k in KEYS if k.field]
        single = {k.field: bool(v[k.key]) if k.kind == "flag" else v[k.key]
                  for k in rows if [r.field for r in rows].count(k.field) == 1}  # fmt: skip
        single["source"] = single["source"] or None
        try:
            return CommissionSettings(
                scene_overrides=self.scene_overrides,
                **single,
                point_spec=DosePointSpec(
                    point_a_height_mm=v["dose_points.point_a_height_mm"],
                    point_a_lateral_mm=v["dose_points.point_a_lateral_mm"],
                    surface_offset_mm=v["dose_points.surface_offset_mm"],
                    depth_mm=v["dose_points.depth_mm"],
                ),
                position_limits_mm=(
                    v["tolerances.position_recommended_mm"],
                    v["tolerances.position_required_mm"],
                ),
                stem_mm=None if v["simulation.whole_channel"] else v["simulation.stem_mm"],
                calibration=self.calibration_record(),
                settings_origin={  # [calibration] only when a calibration file set it
                    k: o
                    for k, o in self.origins.items()
                    if not (k.startswith("calibration.") and o == DEFAULT)
                },
                **self.extra,
            )
        except ConfigError:
            raise
        except RingQAError as exc:
            if "position_limits_mm" in str(exc):
                rec, req = "tolerances.position_recommended_mm", "tolerances.position_required_mm"
                where = [self.origins[k] for k in (rec, req) if self.origins[k] != DEFAULT]
                raise ConfigError(
                    f"{' and '.join(dict.fromkeys(where)) or DEFAULT}: {rec} = {v[rec]!r} "
                    f"({self.origins[rec]}) and {req} = {v[req]!r} ({self.origins[req]}): the "
                    "required tolerance must be >= the recommended one"
                ) from None
            raise

    def calibration_record(self) -> dict[str, Any] | None:
        """The cable calibration file in use (a configuration layer with a ``[calibration]``
        table, from ``ringqa calibrate``): ``file``, ``sha256`` and the table's keys; None
        when no layer has one."""
        keys = [k.key for k in KEYS if k.field == "calibration"]
        origins = {self.origins[k] for k in keys if self.origins.get(k, DEFAULT) != DEFAULT}
        if not origins:
            return None
        origin = sorted(origins)[-1]
        path = ""
        for prefix in ("--config ", "user config "):
            if origin.startswith(prefix):
                path = origin[len(prefix) :]
        from ringqa.provenance import sha256_of

        record: dict[str, Any] = {"file": path}
        if path and Path(path).is_file():
            record["sha256"] = sha256_of(path)
        for k in keys:
            if self.origins.get(k) == origin:
                record[k.split(".", 1)[1]] = self.values[k]
        return record

    def report_fields(self) -> ReportFields:
        """The report's free-text fields (``[report]``)."""
        from ringqa.report.fields import ReportFields

        keys = {f"report.{f.name}": f.name for f in dataclasses.fields(ReportFields)}
        return ReportFields(
            **{name: self.values[k] for k, name in keys.items() if k in self.values}
        )

    def show(self) -> str:
        """The effective settings as TOML-like lines, each with its origin (``ringqa config
        show``)."""
        lines: list[str] = []
        table = None
        items = [(k.key, self.values[k.key]) for k in KEYS]
        items += sorted((k, v) for k, v in self.values.items() if k.startswith("scene."))
        for dotted, value in items:
            head, _, name = dotted.partition(".")
            if head != table:
                if lines:
                    lines.append("")
                lines.append(f"[{head}]")
                table = head
            if head == "scene":
                name = f'"{name}"'
            if value is None:
                line = f"# {name}: not set, taken from the input"
            else:
                line = f"{name} = {_toml_value(value)}"
            lines.append(line.ljust(48) + f"  # {self.origins[dotted]}")
        return "\n".join(lines) + "\n"


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in value) + "]"
    if isinstance(value, float):
        text = f"{value:g}"
        # a float stays a float in TOML (7.0, not 7 as an integer)
        return text if any(c in text for c in ".ein") else text + ".0"
    return str(value)


def effective_config(
    config_file: str | Path | None = None,
    command_line: Mapping[str, Any] | None = None,
    *,
    extra: Mapping[str, Any] | None = None,
    user_file: str | Path | bool | None = True,
) -> EffectiveConfig:
    """Merge default < user config < ``config_file`` < ``command_line``.

    Parameters
    ----------
    config_file : path, optional
        The ``--config FILE``.
    command_line : mapping, optional
        Dotted key -> value given on the command line (only the options the user gave); scene
        overrides as ``scene.<dotted>``.
    extra : mapping, optional
        Settings without a configuration key (see :attr:`EffectiveConfig.extra`).
    user_file : path, bool or None
        True: :func:`user_config_path` (the platform's default file is used when it exists;
        a file named by ``RINGQA_CONFIG`` must exist); a path: that file (must exist); None
        or False: no user configuration.

    Returns
    -------
    EffectiveConfig
    """
    values = {k.key: k.default for k in KEYS}
    origins = {k.key: DEFAULT for k in KEYS}
    layers: list[tuple[str, Mapping[str, Any]]] = []
    user = user_config_path() if user_file is True else (user_file or None)
    named = user_file is not True or os.environ.get(ENV_VAR) is not None
    if user is not None and named and not Path(user).is_file():
        why = f"{ENV_VAR}={user}" if user_file is True else f"user configuration {user}"
        raise ConfigError(
            f"{why}: configuration file not found (a share not mounted?); defaults would be "
            f"used without the site's settings (mount or create it, or set {ENV_VAR}= (empty) "
            "to run without a user configuration)"
        )
    if user is not None and Path(user).is_file():
        layers.append((f"user config {user}", read_config_file(user)))
    if config_file is not None:
        layers.append((f"--config {config_file}", read_config_file(config_file)))
    if command_line:
        layers.append((COMMAND_LINE, dict(command_line)))
    for origin, layer in layers:
        for key, value in layer.items():
            values[key] = value
            origins[key] = origin
    for origin, _ in layers:
        log.info("settings from %s", origin)
    return EffectiveConfig(values, origins, dict(extra or {}))


def config_keys_table() -> str:
    """The keys table of docs/config.md (markdown; a test keeps the two equal)."""
    rows = ["| key | default | unit | allowed | option | meaning |", "|---|---|---|---|---|---|"]
    for k in KEYS:
        default = "from the input" if k.default is None else _toml_value(k.default)
        option = f"`{k.option}`" if k.option else ""
        rows.append(f"| `{k.key}` | {default} | {k.unit} | {k.allowed} | {option} | {k.doc} |")
    return "\n".join(rows)
