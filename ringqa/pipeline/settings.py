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
from ringqa.pipeline.dwells import TANDEM_DWELLS
from ringqa.pipeline.verdicts import DOSE_ACTION_PCT, POSITION_RECOMMENDED_MM, POSITION_REQUIRED_MM
from ringqa.plan import PLAN_STEP_MM, PRESCRIPTION_GY, DosePointSpec
from ringqa.units import m_to_mm

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


#: The names of every commissioning setting, one row per :class:`CommissionSettings` field (but
#: ``settings_origin``, which records where the others came from). A test checks each name
#: against the configuration's keys, the command line's options and results.json, so a renamed
#: or new setting fails until this table says what it is called where.
SETTING_NAMES: tuple[SettingNames, ...] = (
    SettingNames("source", ("simulation.source",), ("--source",), "source"),
    SettingNames("sk_U", ("simulation.sk_u",), ("--sk-u",), "sk_U",
                 "sk_U in Python and results.json, sk_u in the configuration and --sk-u"),
    SettingNames("prescription_gy", ("plan.prescription_gy",), ("--prescription-gy",),
                 "prescription_gy"),
    SettingNames("cable", ("simulation.cable",), ("--cable",), "cable"),
    SettingNames("channel", (), ("--channel",), "channel"),
    SettingNames("point_spec", ("dose_points.point_a_height_mm", "dose_points.point_a_lateral_mm",
                                "dose_points.surface_offset_mm", "dose_points.depth_mm"),
                 (), "dose_points", "point_spec in Python, dose_points elsewhere"),
    SettingNames("plan_step_mm", ("plan.step_mm",), (), "plan_step_mm"),
    SettingNames("tandem_dwells", ("plan.tandem_dwells",), (), "tandem_dwells"),
    SettingNames("position_limits_mm", ("tolerances.position_recommended_mm",
                                        "tolerances.position_required_mm"), (),
                 "position_limits_mm", "one pair in Python and results.json, two keys in the "
                 "configuration"),
    SettingNames("dose_action_pct", ("tolerances.dose_action_pct",), ("--dose-action-pct",),
                 "dose_action_pct"),
    SettingNames("register", ("simulation.register",), ("--register",), "register",
                 "register here; registration in summary.csv and the reference check"),
    SettingNames("stem_mm", ("simulation.stem_mm", "simulation.whole_channel"),
                 ("--stem-mm", "--whole-channel"), "stem_mm",
                 "None (the whole channel) is simulation.whole_channel / --whole-channel"),
    SettingNames("cross_check", ("simulation.cross_check",), ("--cross-check", "--no-cross-check"),
                 None, "its outcome is results.json numerical_check.cross_check"),
    SettingNames("centreline_correction", (), ("--centreline-correction",),
                 "centreline_correction"),
    SettingNames("require_measured", (), ("--centreline-reference",), None,
                 "require_measured = not --centreline-reference (the same concept, inverted)"),
    SettingNames("scene_overrides", ("scene.*",), ("--set",), "scene_overrides"),
    SettingNames("structures", (), ("--structures",), None,
                 "the file is in the provenance's inputs"),
    SettingNames("lumen_mm", (), ("--lumen-mm",), None,
                 "said in the notes (each channel's lumen and where it comes from)"),
    SettingNames("measured", (), ("--measured",), None,
                 "the file is in the provenance's inputs; its points in results.json "
                 "measured_points"),
    SettingNames("calibration", ("calibration.command", "calibration.created_utc",
                                 "calibration.calibration_json_sha256"), (), None,
                 "the [calibration] table of a calibrated_cable.toml; results.json settings."
                 "calibration (only when one is used) adds the file and its SHA-256"),
)  # fmt: skip
