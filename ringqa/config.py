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
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ringqa.errors import RingQAError
from ringqa.geometry.registration import REGISTER_MODES
from ringqa.pipeline.dwells import TANDEM_DWELLS
from ringqa.pipeline.settings import DEFAULT_STEM_MM, CommissionSettings
from ringqa.pipeline.verdicts import DOSE_ACTION_PCT, POSITION_RECOMMENDED_MM, POSITION_REQUIRED_MM
from ringqa.plan import PLAN_STEP_MM, PRESCRIPTION_GY, DosePointSpec
from ringqa.simulation.scene_keys import KEYS as SCENE_KEYS
from ringqa.textio import read_toml

if TYPE_CHECKING:  # imported where used: ringqa.report's package loads reportlab and pandas
    from ringqa.report.fields import ReportFields

log = logging.getLogger(__name__)

#: environment variable naming the user configuration file ("" = none)
ENV_VAR = "RINGQA_CONFIG"
#: origin of a built-in default
DEFAULT = "default"
#: origin of a command-line option
COMMAND_LINE = "command line"
#: the cable models a commissioning run can simulate
CABLES = ("flexitron", "microselectron")


class ConfigError(RingQAError):
    """A configuration file is unreadable or holds an unknown key or a bad value."""


@dataclass(frozen=True)
class ConfigKey:
    """One configuration key.

    Attributes
    ----------
    key : str
        ``table.name`` as written in the file.
    unit : str
        User unit (``mm``, ``Gy``, ``%``, ``U``; ``""`` for text, flags and choices).
    default : object
        Built-in default (None: decided by the input, e.g. the RT Plan's source).
    kind : str
        ``"number"``, ``"int"``, ``"text"``, ``"choice"`` or ``"flag"``.
    low, high : float
        Allowed range of a number (``low`` exclusive when ``low_open``).
    low_open : bool
        ``low`` itself is not allowed (``> low``).
    choices : tuple of str
        Allowed values of a choice.
    option : str
        The command-line option that overrides it (``""``: none).
    doc : str
        What it means (docs table).
    """

    key: str
    unit: str
    default: Any
    kind: str
    doc: str
    low: float = 0.0
    high: float = math.inf
    low_open: bool = True
    choices: tuple[str, ...] = ()
    option: str = ""

    @property
    def allowed(self) -> str:
        """The allowed values in words (``"> 0 and <= 100"``, ``"none, rigid"``)."""
        if self.kind == "choice":
            return "one of " + ", ".join(self.choices)
        if self.kind == "text":
            return "text"
        if self.kind == "flag":
            return "true or false"
        lo = f"{'>' if self.low_open else '>='} {self.low:g}"
        return lo if math.isinf(self.high) else f"{lo} and <= {self.high:g}"

    def problem(self, value) -> str | None:
        """What is wrong with ``value`` (None if nothing)."""
        if self.kind == "flag":
            return None if isinstance(value, bool) else "must be true or false"
        if self.kind in ("text", "choice"):
            if not isinstance(value, str):
                return "must be text (in quotes)"
            if self.kind == "choice" and value not in self.choices:
                return f"allowed: {self.allowed}"
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            return f"must be a number ({self.allowed})"
        if self.kind == "int" and not isinstance(value, int):
            return f"must be a whole number ({self.allowed})"
        if not math.isfinite(value):
            return f"must be a finite number ({self.allowed})"
        too_low = value <= self.low if self.low_open else value < self.low
        if too_low or value > self.high:
            unit = f" {self.unit}" if self.unit else ""
            return f"out of range: allowed {self.allowed}{unit}"
        return None


def _num(key, unit, default, doc, low=0.0, high=math.inf, low_open=True, option="", kind="number"):
    return ConfigKey(key, unit, default, kind, doc, low, high, low_open, (), option)


#: every configuration key outside ``[scene]``, in the order of docs/config.md
KEYS: tuple[ConfigKey, ...] = (
    _num(
        "tolerances.position_recommended_mm",
        "mm",
        POSITION_RECOMMENDED_MM,
        "recommended source-position tolerance (PASS up to it)",
        high=10.0,
    ),
    _num(
        "tolerances.position_required_mm",
        "mm",
        POSITION_REQUIRED_MM,
        "required source-position tolerance (WARN up to it, FAIL beyond); >= recommended",
        high=10.0,
    ),
    _num(
        "tolerances.dose_action_pct",
        "%",
        DOSE_ACTION_PCT,
        "dose-difference action level",
        high=100.0,
        option="--dose-action-pct",
    ),
    _num(
        "plan.prescription_gy",
        "Gy",
        PRESCRIPTION_GY,
        "mean Point A dose of the standard plan",
        high=50.0,
        option="--prescription-gy",
    ),
    _num(
        "plan.step_mm",
        "mm",
        PLAN_STEP_MM,
        "dwell spacing of the standard plan (a multiple of the reference path's step)",
        high=50.0,
    ),
    _num(
        "plan.tandem_dwells",
        "",
        TANDEM_DWELLS,
        "tandem dwells of the standard plan when the tandem has no measured path (0: none)",
        high=100,
        low_open=False,
        kind="int",
    ),
    _num(
        "dose_points.point_a_height_mm",
        "mm",
        DosePointSpec().point_a_height_mm,
        "height of Point A above the ring channel's plane",
        high=100.0,
        low_open=False,
    ),
    _num(
        "dose_points.point_a_lateral_mm",
        "mm",
        DosePointSpec().point_a_lateral_mm,
        "distance of Point A from the ring's axis",
        high=100.0,
        low_open=False,
    ),
    _num(
        "dose_points.surface_offset_mm",
        "mm",
        DosePointSpec().surface_offset_mm,
        "lateral ring surface outside the channel centreline",
        high=50.0,
        low_open=False,
    ),
    _num(
        "dose_points.depth_mm",
        "mm",
        DosePointSpec().depth_mm,
        "depth of the deeper vaginal points beyond the surface",
        high=50.0,
        low_open=False,
    ),
    ConfigKey(
        "simulation.source",
        "",
        None,
        "text",
        "TG-43 source (flexisource, mhdr-v2, ...; default: the RT Plan's, else flexisource)",
        option="--source",
    ),
    _num(
        "simulation.sk_u",
        "U",
        None,
        "source air-kerma strength (default: the RT Plan's)",
        high=1e6,
        option="--sk-u",
    ),
    ConfigKey(
        "simulation.cable",
        "",
        None,
        "choice",
        "cable model (default: the cable of the plan's source)",
        choices=CABLES,
        option="--cable",
    ),
    ConfigKey(
        "simulation.register",
        "",
        "none",
        "choice",
        "registration of the reference path to the channel",
        choices=REGISTER_MODES,
        option="--register",
    ),
    _num(
        "simulation.stem_mm",
        "mm",
        DEFAULT_STEM_MM,
        "straight channel simulated before the first bend",
        high=2000.0,
        option="--stem-mm",
    ),
    ConfigKey(
        "simulation.whole_channel",
        "",
        False,
        "flag",
        "simulate the whole channel (ignores stem_mm)",
        option="--whole-channel",
    ),
    ConfigKey(
        "simulation.cross_check",
        "",
        False,
        "flag",
        "also run the flexible-element engine and compare its dwells (the cross-check)",
        option="--cross-check",
    ),
    ConfigKey("report.institution", "", "", "text", "hospital / department"),
    ConfigKey("report.physicist", "", "", "text", "the physicist who signs"),
    ConfigKey("report.afterloader", "", "", "text", "afterloader model and serial number"),
    ConfigKey("report.applicator_serial", "", "", "text", "applicator serial or part number"),
    ConfigKey(
        "report.source_calibration",
        "",
        "",
        "text",
        "source serial and calibration (certificate, date)",
    ),
    ConfigKey("report.notes", "", "", "text", "free notes printed above the signature block"),
    ConfigKey(
        "report.strict",
        "",
        False,
        "flag",
        "exit status 1 when a verdict is FAIL or ACTION (for scripts; the files are written "
        "either way)",
        option="--strict",
    ),
)
_BY_KEY = {k.key: k for k in KEYS}
TABLES = ("tolerances", "plan", "dose_points", "simulation", "scene", "report")
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
        try:
            return CommissionSettings(
                scene_overrides=self.scene_overrides,
                source=v["simulation.source"] or None,
                prescription_gy=v["plan.prescription_gy"],
                sk_U=v["simulation.sk_u"],
                cable=v["simulation.cable"],
                point_spec=DosePointSpec(
                    point_a_height_mm=v["dose_points.point_a_height_mm"],
                    point_a_lateral_mm=v["dose_points.point_a_lateral_mm"],
                    surface_offset_mm=v["dose_points.surface_offset_mm"],
                    depth_mm=v["dose_points.depth_mm"],
                ),
                plan_step_mm=v["plan.step_mm"],
                tandem_dwells=v["plan.tandem_dwells"],
                position_limits_mm=(
                    v["tolerances.position_recommended_mm"],
                    v["tolerances.position_required_mm"],
                ),
                dose_action_pct=v["tolerances.dose_action_pct"],
                register=v["simulation.register"],
                stem_mm=None if v["simulation.whole_channel"] else v["simulation.stem_mm"],
                cross_check=bool(v["simulation.cross_check"]),
                settings_origin=dict(self.origins),
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
