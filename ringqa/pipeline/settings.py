"""The settings of a commissioning run, in one checked object: :class:`CommissionSettings`.

Every field has the default of the command line (``ringqa commission``); a bad value is refused
when the object is made, with a message that names the field (or its command-line option) and
says what to give instead.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ringqa.errors import RingQAError
from ringqa.geometry.registration import REGISTER_MODES
from ringqa.geometry.stem import DEFAULT_STEM_M
from ringqa.plan import PLAN_STEP_MM, PRESCRIPTION_GY, DosePointSpec
from ringqa.units import m_to_mm

#: Position tolerances, mm: recommended and required (AAPM MPPG 13.a, 2023; TG-56).
POSITION_RECOMMENDED_MM = 1.0
POSITION_REQUIRED_MM = 2.0
#: Default dose-difference action level, %.
DOSE_ACTION_PCT = 5.0
#: Default number of tandem dwells (5 mm apart) when the tandem has no measured path
#: (the Oncentra 26/60 standard plan has 7).
TANDEM_DWELLS = 7

#: The origin of a setting left at its built-in default (``settings_origin``; :mod:`ringqa.config`).
DEFAULT_ORIGIN = "default"

#: Default straight channel simulated before the first bend, mm.
DEFAULT_STEM_MM = float(m_to_mm(DEFAULT_STEM_M))


def _is_number(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)


@dataclass(frozen=True)
class CommissionSettings:
    """How to commission: plan, tolerances, source and simulation settings (mm, Gy, %, U).

    Attributes
    ----------
    scene_overrides : mapping of str to value
        Dotted scene keys -> values in user units (as ``--set``), e.g.
        ``{"solver.increment_mm": 0.5}``.
    source : str or tg43.Source or None
        TG-43 source; None: the RT Plan's source, else ``"flexisource"``.
    prescription_gy : float
        Mean Point A dose of the standard plan, Gy (7); > 0.
    sk_U : float or None
        Air-kerma strength, U (None: the RT Plan's, else 40820 U; doses do not depend on it).
    cable : str or None
        Instrument preset for the simulation; None (default): the cable of the plan's source's
        afterloader (:data:`~ringqa.pipeline.simulate.SOURCE_CABLE`: Flexisource -> flexitron,
        mHDR-v2 -> microselectron), the Flexitron cable for other sources (said in the report).
    channel : str
        The applicator channel to simulate (``"ring"``; a name or the plan's channel number;
        ``"ring"`` for an applicator of another family: its first channel).
    point_spec : DosePointSpec
        Where the standard dose points are.
    plan_step_mm : float
        Dwell spacing of the standard plan, mm (5); a multiple of the measured path's step.
    tandem_dwells : int
        Tandem dwells in the standard plan when the tandem has no measured path (7; 0: none).
    position_limits_mm : (float, float)
        Recommended and required source-position tolerance, mm (1, 2).
    dose_action_pct : float
        Dose-difference action level, % (5); > 0.
    register : str
        How the reference path is registered to the CHANNEL before the comparison
        (``--register``): ``"none"`` (default: compared as supplied), ``"plane-height"`` (a
        planar path at constant height moved into the ring channel's plane) or ``"rigid"``
        (see :mod:`ringqa.geometry.registration`). Raw and registered numbers are both reported.
    stem_mm : float or None
        Straight channel kept before the first bend in the simulation, mm (60, the shipped rings'
        stem; None: the whole channel). See :mod:`ringqa.geometry.stem`.
    cross_check : bool
        Also run the flexible-element engine and compare its dwells with the reported ones
        (on by default; ``--no-cross-check``; :func:`ringqa.pipeline.simulate.start_cross_check`).
    centreline_correction : str, Path or None
        A CT/film centreline segment (CSV/JSON, mm, proximal -> distal, in the applicator's frame)
        spliced over the channel's library centreline (``--centreline-correction``;
        :mod:`ringqa.io.correction`).
    require_measured : bool or None
        Refuse an applicator without a measured source path. None: refuse for user files
        (folder, JSON, RT Plan), accept shipped applicators and Applicator objects (compared
        simulated vs centreline).
    settings_origin : mapping of str to str
        Where each setting came from (configuration key -> ``"default"``, ``"user config
        <path>"``, ``"--config <path>"``, ``"command line"``; :mod:`ringqa.config`); carried
        into the result (``results.json`` ``settings_origin``). Empty when built in Python.
    structures : str or Path or None
        An RT Structure Set whose open contours are the RT Plan's channels
        (:mod:`ringqa.io.rtstruct`; ``--structures``).
    lumen_mm : float or None
        Lumen diameter (mm) of the channels read from a structure set (``--lumen-mm``; None:
        the per-applicator lumen table).
    measured : str or Path or None
        A measured source path file (CSV/JSON, mm; any subset of relative positions with
        ``sd_mm`` and ``method``: :mod:`ringqa.pipeline.measured_points`) of the channel, in
        place of the input's own (``--measured``); the input's own dense path (an RT Plan's
        library path) then carries the standard plan.
    calibration : mapping or None
        The cable calibration file the scene keys came from (``[calibration]`` of a
        ``ringqa calibrate`` calibrated_cable.toml given as configuration): ``file``,
        ``sha256`` and its ``[calibration]`` keys; named in results.json and the report.

    Raises
    ------
    RingQAError
        A value out of range or of the wrong type (the message names the field and the fix).
    """

    scene_overrides: Mapping[str, Any] = field(default_factory=dict)
    source: Any = None
    prescription_gy: float = PRESCRIPTION_GY
    sk_U: float | None = None
    cable: str | None = None
    channel: str = "ring"
    point_spec: DosePointSpec = field(default_factory=DosePointSpec)
    plan_step_mm: float = PLAN_STEP_MM
    tandem_dwells: int = TANDEM_DWELLS
    position_limits_mm: tuple[float, float] = (POSITION_RECOMMENDED_MM, POSITION_REQUIRED_MM)
    dose_action_pct: float = DOSE_ACTION_PCT
    register: str = "none"
    stem_mm: float | None = DEFAULT_STEM_MM
    cross_check: bool = True
    centreline_correction: str | Path | None = None
    require_measured: bool | None = None
    settings_origin: Mapping[str, str] = field(default_factory=dict)
    structures: str | Path | None = None
    lumen_mm: float | None = None
    measured: str | Path | None = None
    calibration: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        def keep(name: str, value) -> None:
            object.__setattr__(self, name, value)

        if self.lumen_mm is not None and not (_is_number(self.lumen_mm) and
                                              0 < self.lumen_mm <= 10):  # fmt: skip
            raise RingQAError(
                f"--lumen-mm {self.lumen_mm!r}: must be a lumen diameter in mm, > 0 and <= 10 "
                "(gynaecological applicator channels are 1.5-4 mm)"
            )

        if not (_is_number(self.prescription_gy) and self.prescription_gy > 0):
            raise RingQAError(f"--prescription-gy {self.prescription_gy!r}: must be a number > 0")
        limits = self.position_limits_mm
        try:
            pair = tuple(limits)
        except TypeError:
            pair = ()
        if not (len(pair) == 2 and all(_is_number(x) for x in pair) and 0 < pair[0] <= pair[1]):
            raise RingQAError(
                f"position_limits_mm {limits!r}: give (recommended, required) with "
                "0 < recommended <= required, e.g. (1, 2)"
            )
        if not (_is_number(self.dose_action_pct) and self.dose_action_pct > 0):
            raise RingQAError(f"--dose-action-pct {self.dose_action_pct!r}: must be a number > 0")
        if not (_is_number(self.plan_step_mm) and self.plan_step_mm > 0):
            raise RingQAError(
                f"plan_step_mm {self.plan_step_mm!r}: must be a number of mm > 0 (the standard "
                "plan's dwell spacing, e.g. 5)"
            )
        n_tandem = self.tandem_dwells
        if not (isinstance(n_tandem, numbers.Integral) and not isinstance(n_tandem, bool)
                and n_tandem >= 0):  # fmt: skip
            raise RingQAError(
                f"tandem_dwells {self.tandem_dwells!r}: must be a whole number >= 0 (0: no "
                "tandem dwells in the standard plan)"
            )
        if self.sk_U is not None and not (_is_number(self.sk_U) and self.sk_U > 0):
            raise RingQAError(
                f"sk_U {self.sk_U!r}: must be an air-kerma strength in U > 0, or None (the RT "
                "Plan's, else 40820 U)"
            )
        for name in ("cable", "channel"):
            value = getattr(self, name)
            if name == "cable" and value is None:
                continue
            if not (isinstance(value, str) and value.strip()):
                raise RingQAError(
                    f"{name} {value!r}: must be a name, e.g. "
                    + ('"flexitron"' if name == "cable" else '"ring"')
                )
        if not isinstance(self.point_spec, DosePointSpec):
            raise RingQAError(
                f"point_spec {self.point_spec!r}: must be a ringqa.plan.DosePointSpec"
            )
        if self.register not in REGISTER_MODES:
            raise RingQAError(
                f"--register {self.register!r}: unknown registration mode; choose one of "
                f"{', '.join(REGISTER_MODES)} (none: the reference path as supplied)"
            )
        if self.stem_mm is not None and not (_is_number(self.stem_mm) and self.stem_mm > 0):
            raise RingQAError(
                f"--stem-mm {self.stem_mm!r}: must be a length in mm > 0 (the straight channel "
                "simulated before the first bend, e.g. 60), or None for the whole channel"
            )
        if self.measured is not None and not isinstance(self.measured, str | Path):
            raise RingQAError(
                f"--measured {self.measured!r}: give the path of a measured source path file "
                "(CSV/JSON, mm)"
            )
        corr = self.centreline_correction
        if corr is not None and not isinstance(corr, str | Path):
            raise RingQAError(
                f"--centreline-correction {corr!r}: give the path of a CSV/JSON point file"
            )
        if self.require_measured not in (None, True, False):
            raise RingQAError(
                f"require_measured {self.require_measured!r}: must be True, False or None "
                "(None: required for user files only)"
            )
        overrides = self.scene_overrides
        if not isinstance(overrides, Mapping) or not all(isinstance(k, str) for k in overrides):
            raise RingQAError(
                f"scene_overrides {overrides!r}: must map dotted scene keys to values, e.g. "
                '{"solver.increment_mm": 0.5}'
            )
        origin = self.settings_origin
        if not isinstance(origin, Mapping):
            raise RingQAError(
                f"settings_origin {origin!r}: must map setting names to where they came from"
            )
        keep("settings_origin", {str(k): str(v) for k, v in origin.items()})
        keep("scene_overrides", dict(overrides))
        keep("prescription_gy", float(self.prescription_gy))
        keep("position_limits_mm", (float(pair[0]), float(pair[1])))
        keep("dose_action_pct", float(self.dose_action_pct))
        keep("plan_step_mm", float(self.plan_step_mm))
        keep("tandem_dwells", int(n_tandem))
        if self.sk_U is not None:
            keep("sk_U", float(self.sk_U))
        if self.stem_mm is not None:
            keep("stem_mm", float(self.stem_mm))


@dataclass(frozen=True)
class Setting:
    """One commissioning setting: its configuration key, unit, default, range, meaning,
    command-line option, :class:`CommissionSettings` field and ``results.json`` key (the one
    table every place reads: :data:`SETTINGS`).

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
        The command-line option that overrides it (``""``: none). Given as True, it is made
        from the key's name: ``--`` + the name with ``-`` for ``_`` (``simulation.stem_mm`` ->
        ``--stem-mm``), so the name is written once.
    doc : str
        What it means (docs table).
    field : str
        The :class:`CommissionSettings` field it sets (``""``: none; the report's fields).
        Given as True: the key's name (``simulation.register`` -> ``register``).
    results_key : str or None
        Its key in ``results.json`` ``settings`` (None: not recorded there). By default the
        field's name (None without a field).
    metavar : str
        The option's value placeholder in ``--help`` (``MM``, ``GY``; flags: ``""``).
    help : str
        The option's ``--help`` text (default: :attr:`doc`).
    negatable : bool
        A flag that also has ``--no-<name>`` (argparse's BooleanOptionalAction).
    sweep : bool
        A sweep spec's ``[settings]`` table may set it (:mod:`ringqa.sweep.spec`).
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
    option: str | bool = ""
    field: str | bool = ""
    results_key: str | bool | None = True
    metavar: str = ""
    help: str = ""
    negatable: bool = False
    sweep: bool = False

    def __post_init__(self) -> None:
        name = self.key.split(".", 1)[1]
        if self.option is True:
            object.__setattr__(self, "option", "--" + name.replace("_", "-"))
        if self.field is True:
            object.__setattr__(self, "field", name)
        if self.results_key is True:
            object.__setattr__(self, "results_key", self.field or None)

    @property
    def table(self) -> str:
        """The configuration table the key is in (``simulation`` of ``simulation.register``):
        the group the report's settings page shows it in."""
        return self.key.split(".", 1)[0]

    @property
    def name(self) -> str:
        """The key's name inside its table (``register`` of ``simulation.register``)."""
        return self.key.split(".", 1)[1]

    @property
    def record(self) -> str:
        """The name under which a run records its value (:meth:`value_in`): the results.json
        key, else the :class:`CommissionSettings` field, else the key's name (the report
        fields, :class:`ringqa.report.fields.ReportFields`)."""
        return self.results_key or self.field or self.name

    def value_in(self, record: Mapping[str, Any]) -> Any:
        """This setting's value in a run's ``record`` (results.json ``settings`` with the
        report fields and the settings results.json does not keep), or :data:`NOT_RECORDED`.

        ``record[self.record]`` as it is, with three forms of one record holding several keys:
        a table (``dose_points``, ``calibration``) holds each key under its name; a list
        (``position_limits_mm``) holds the keys that share it in the order of :data:`SETTINGS`;
        a flag recorded under a number (``simulation.whole_channel`` under ``stem_mm``) is on
        when the number is None.
        """
        if self.record not in record:
            return NOT_RECORDED
        value = record[self.record]
        if isinstance(value, Mapping):
            return value.get(self.name, NOT_RECORDED)
        if self.kind == "flag" and not isinstance(value, bool):
            return value is None
        if isinstance(value, list | tuple):
            share = [s for s in SETTINGS if s.record == self.record and s.kind != "flag"]
            if len(share) > 1 and self in share and len(value) == len(share):
                return value[share.index(self)]
        return value

    @property
    def dest(self) -> str:
        """The option's argparse destination (``--sk-u`` -> ``sk_u``; ``""``: no option)."""
        return self.option.lstrip("-").replace("-", "_")

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


class _NotRecorded:
    """The value of a setting the run did not record (:data:`NOT_RECORDED`)."""

    def __repr__(self) -> str:
        return "NOT_RECORDED"


#: What :meth:`Setting.value_in` gives for a setting the run's record does not hold.
NOT_RECORDED = _NotRecorded()


def _num(
    key,
    unit,
    default,
    doc,
    low=0.0,
    high=math.inf,
    low_open=True,
    option="",
    kind="number",
    **names,
):
    return Setting(key, unit, default, kind, doc, low, high, low_open, (), option, **names)


#: The cable models a commissioning run can simulate.
CABLES = ("flexitron", "microselectron")

#: THE settings table: every configuration key outside ``[scene]`` (in the order of
#: docs/config.md) with its unit, default, range, meaning, command-line option (and its help),
#: field and results.json key. ``ringqa commission``'s options are made from it
#: (:func:`ringqa.cli.commission.add_setting_options`), the configuration is checked against it
#: (:meth:`Setting.problem`), docs/config.md's table is printed from it.
SETTINGS: tuple[Setting, ...] = (
    _num(
        "tolerances.position_recommended_mm",
        "mm",
        POSITION_RECOMMENDED_MM,
        "recommended source-position tolerance (PASS up to it)",
        high=10.0,
        field="position_limits_mm",
    ),
    _num(
        "tolerances.position_required_mm",
        "mm",
        POSITION_REQUIRED_MM,
        "required source-position tolerance (WARN up to it, FAIL beyond); >= recommended",
        high=10.0,
        field="position_limits_mm",
    ),
    _num(
        "tolerances.dose_action_pct",
        "%",
        DOSE_ACTION_PCT,
        "dose-difference action level",
        high=100.0,
        option=True,
        sweep=True,
        field=True,
        metavar="PCT",
        help="dose-difference action level, %% (default 5)",
    ),
    _num(
        "plan.prescription_gy",
        "Gy",
        PRESCRIPTION_GY,
        "mean Point A dose of the standard plan",
        high=50.0,
        option=True,
        sweep=True,
        field=True,
        metavar="GY",
        help="mean Point A dose of the standard plan, Gy (default 7)",
    ),
    _num(
        "plan.step_mm",
        "mm",
        PLAN_STEP_MM,
        "dwell spacing of the standard plan (a multiple of the reference path's step)",
        high=50.0,
        field="plan_step_mm",
    ),
    _num(
        "plan.tandem_dwells",
        "",
        TANDEM_DWELLS,
        "tandem dwells of the standard plan when the tandem has no measured path (0: none)",
        high=100,
        low_open=False,
        kind="int",
        field=True,
    ),
    _num(
        "dose_points.point_a_height_mm",
        "mm",
        DosePointSpec().point_a_height_mm,
        "height of Point A above the ring channel's plane",
        high=100.0,
        low_open=False,
        field="point_spec",
        results_key="dose_points",
    ),
    _num(
        "dose_points.point_a_lateral_mm",
        "mm",
        DosePointSpec().point_a_lateral_mm,
        "distance of Point A from the ring's axis",
        high=100.0,
        low_open=False,
        field="point_spec",
        results_key="dose_points",
    ),
    _num(
        "dose_points.surface_offset_mm",
        "mm",
        DosePointSpec().surface_offset_mm,
        "lateral ring surface outside the channel centreline",
        high=50.0,
        low_open=False,
        field="point_spec",
        results_key="dose_points",
    ),
    _num(
        "dose_points.depth_mm",
        "mm",
        DosePointSpec().depth_mm,
        "depth of the deeper vaginal points beyond the surface",
        high=50.0,
        low_open=False,
        field="point_spec",
        results_key="dose_points",
    ),
    Setting(
        "simulation.source",
        "",
        None,
        "text",
        "TG-43 source (flexisource, mhdr-v2, ...; default: the RT Plan's, else flexisource)",
        option=True,
        sweep=True,
        field=True,
        metavar="NAME",
        help="TG-43 source (default: the RT Plan's, else flexisource)",
    ),
    _num(
        "simulation.sk_u",
        "U",
        None,
        "source air-kerma strength (default: the RT Plan's)",
        high=1e6,
        option=True,
        sweep=True,
        field="sk_U",
        metavar="U",
        help="source air-kerma strength, U (default: the RT Plan's; needed to check a plan "
        "without one against its planning-system doses)",
    ),
    Setting(
        "simulation.cable",
        "",
        None,
        "choice",
        "cable model (default: the cable of the plan's source)",
        choices=CABLES,
        option=True,
        sweep=True,
        field=True,
        metavar="NAME",
        help="source cable model (flexitron, microselectron; default: the cable of the plan's "
        "source)",
    ),
    Setting(
        "simulation.register",
        "",
        "none",
        "choice",
        "registration of the reference path to the channel",
        choices=REGISTER_MODES,
        option=True,
        sweep=True,
        field=True,
        metavar="MODE",
        help="how the reference source path is aligned with the channel before comparing: "
        "none (default: as supplied), plane-height or rigid",
    ),
    _num(
        "simulation.stem_mm",
        "mm",
        DEFAULT_STEM_MM,
        "straight channel simulated before the first bend",
        high=2000.0,
        option=True,
        sweep=True,
        field=True,
        metavar="MM",
        help="straight channel simulated before the first bend, mm (default 60)",
    ),
    Setting(
        "simulation.whole_channel",
        "",
        False,
        "flag",
        "simulate the whole channel (ignores stem_mm)",
        option=True,
        field="stem_mm",
        help="simulate the whole channel (however long its straight shaft)",
    ),
    Setting(
        "simulation.cross_check",
        "",
        True,
        "flag",
        "also run the flexible-element engine and compare its dwells (the cross-check; "
        "--no-cross-check turns it off)",
        option=True,
        field=True,
        results_key=None,  # its outcome is results.json numerical_check.cross_check
        negatable=True,
        help="also run the flexible-element engine (model.formulation = flexible) and compare "
        "its dwells; a disagreement above max(0.2 mm, 2 x the numerical errors) fails the "
        "numerics (on by default; --no-cross-check turns it off and the report says so)",
    ),
    Setting("report.institution", "", "", "text", "hospital / department"),
    Setting("report.physicist", "", "", "text", "the physicist who signs"),
    Setting("report.afterloader", "", "", "text", "afterloader model and serial number"),
    Setting("report.applicator_serial", "", "", "text", "applicator serial or part number"),
    Setting(
        "report.source_calibration",
        "",
        "",
        "text",
        "source serial and calibration (certificate, date)",
    ),
    Setting("report.notes", "", "", "text", "free notes printed above the signature block"),
    Setting(
        "report.strict",
        "",
        False,
        "flag",
        "exit status 1 when a verdict is FAIL or ACTION (for scripts; the files are written "
        "either way)",
        option=True,
        help="exit status 1 when a verdict is FAIL or ACTION (the files are written either "
        "way; configuration key report.strict)",
    ),
    # the [calibration] table ringqa calibrate writes into calibrated_cable.toml: the
    # commissioning report names the file (with its SHA-256) and these (CommissionSettings
    # .calibration)
    *(
        # results.json settings.calibration: only when one is used (RunSettings.as_dict)
        Setting(f"calibration.{name}", "", "", "text", doc, field="calibration", results_key=None)
        for name, doc in (
            ("command", "the ringqa calibrate command that wrote this file (a calibrated cable)"),
            ("created_utc", "when the calibration was made (UTC)"),
            (
                "calibration_json_sha256",
                "SHA-256 of the calibration.json written beside this file (the fit's record)",
            ),
        )
    ),
)


@dataclass(frozen=True)
class SettingNames:
    """Every name one commissioning setting goes by (:data:`SETTING_NAMES`).

    Attributes
    ----------
    field : str
        The :class:`CommissionSettings` field.
    config_keys : tuple of str
        Its keys in the clinic configuration (:data:`ringqa.config.KEYS`; unit, default, range
        and help are there); ``scene.*`` for the scene overrides.
    cli_flags : tuple of str
        Its ``ringqa commission`` options.
    results_key : str or None
        Its key in ``results.json`` ``settings`` (:meth:`~ringqa.pipeline.result.RunSettings
        .as_dict`); None when the run records it elsewhere (the notes, the provenance's inputs).
    note : str
        Where a name differs from the field's (the drift the table makes visible).
    """

    field: str
    config_keys: tuple[str, ...] = ()
    cli_flags: tuple[str, ...] = ()
    results_key: str | None = None
    note: str = ""


def _names(field: str, results_key: str | None = None, note: str = "", flags=(),
           keys=()) -> SettingNames:  # fmt: skip
    """A row of :data:`SETTING_NAMES`: the configuration keys, options and results.json key of
    ``field`` read from :data:`SETTINGS` (a negatable flag's ``--no-`` form too), plus the
    options and keys that are not configuration keys (``flags``, ``keys``); ``results_key``
    for a field without a row in the table."""
    rows = [s for s in SETTINGS if s.field == field]
    options = [s.option for s in rows if s.option]
    options += ["--no-" + s.option[2:] for s in rows if s.option and s.negatable]
    if rows:
        results_key = rows[0].results_key
    return SettingNames(field, (*(s.key for s in rows), *keys), (*options, *flags), results_key,
                        note)  # fmt: skip


#: Where a setting's names differ from its field's (the drift the table makes visible), by field.
NAME_NOTES = {
    "sk_U": "sk_U in Python and results.json, sk_u in the configuration and --sk-u",
    "point_spec": "point_spec in Python, dose_points elsewhere",
    "position_limits_mm": "one pair in Python and results.json, two keys in the configuration",
    "register": "register here; registration in summary.csv and the reference check",
    "stem_mm": "None (the whole channel) is simulation.whole_channel / --whole-channel",
    "cross_check": "its outcome is results.json numerical_check.cross_check",
    "calibration": "the [calibration] table of a calibrated_cable.toml; results.json "
    "settings.calibration (only when one is used) adds the file and its SHA-256",
}

#: The names of every commissioning setting, one row per :class:`CommissionSettings` field (but
#: ``settings_origin``, which records where the others came from): the fields of
#: :data:`SETTINGS` (keys, options and results.json key read from it, so a name is written
#: once), then the settings that are options or arguments only. A test checks each name
#: against the configuration's keys, the command line's options and results.json, so a renamed
#: or new setting fails until this table says what it is called where.
SETTING_NAMES: tuple[SettingNames, ...] = (
    *(_names(f, note=NAME_NOTES.get(f, "")) for f in dict.fromkeys(s.field for s in SETTINGS)
      if f),
    _names("channel", "channel", flags=("--channel",)),
    _names("centreline_correction", "centreline_correction",
           flags=("--centreline-correction",)),
    _names("require_measured", None,
           "require_measured = not --centreline-reference (the same concept, inverted)",
           flags=("--centreline-reference",)),
    _names("scene_overrides", "scene_overrides", flags=("--set",), keys=("scene.*",)),
    _names("structures", None, "the file is in the provenance's inputs", flags=("--structures",)),
    _names("lumen_mm", None, "said in the notes (each channel's lumen and where it comes from)",
           flags=("--lumen-mm",)),
    _names("measured", None, "the file is in the provenance's inputs; its points in results.json "
           "measured_points", flags=("--measured",)),
)  # fmt: skip


def results_keys() -> tuple[str, ...]:
    """The keys of ``results.json`` ``settings`` that record a setting, each once, in the order
    of :data:`SETTING_NAMES` (the table's fields first): what
    :meth:`ringqa.pipeline.result.RunSettings.as_dict` writes (beside the simulated scene and,
    when one is used, the calibration file)."""
    return tuple(dict.fromkeys(n.results_key for n in SETTING_NAMES if n.results_key))
