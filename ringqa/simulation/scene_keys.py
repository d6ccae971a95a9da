"""Every scene key, described once: name, unit, type, default, range and meaning.

A scene file (TOML) uses these keys in user units (the unit is in the name: ``increment_mm``,
``speed_mm_s``, ``time_step_s``); the :class:`~ringqa.simulation.scene.Scene` dataclasses hold the
same settings in SI. :data:`KEYS` is the one description both sides read:

- the scene dataclasses take their defaults from it and validate their fields against it in
  ``__post_init__`` (so a scene built in Python is checked exactly like one read from a file);
- the TOML reader, the writer and ``--set`` (:mod:`ringqa.simulation.scenefile`) convert with it;
- the keys table of ``data/scenes/README.md`` is generated from it (:func:`markdown_table`; a test
  keeps the two equal) and every error message names the key as written here.

The unit conversions are :mod:`ringqa.units`' (the one place where units are converted).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.errors import SceneError
from ringqa.units import M_PER_MM

NUM = (int, float)

CHANNEL_KINDS = ("applicator", "straight", "arc", "helix", "s-curve", "points")
LUMEN_KINDS = ("circular", "u", "stepped")
FLAT_TOWARDS = ("bend_outside", "ring_outside", "cranial", "caudal")
FRICTION_LAWS = ("none", "coulomb", "stribeck")
SOLVER_KINDS = ("quasistatic", "dynamic")
INTEGRATORS = ("backward_euler", "bdf2")
MOTION_KINDS = ("constant", "stepwise", "retract")
PRESETS = ("flexitron", "microselectron", "catheter")
#: the engine's discretisation of the instrument (``model.formulation``): the paper's rigid links
#: with hinge springs, or flexible (Kirchhoff) beam elements (:mod:`ringqa.simulation.flexible`)
FORMULATIONS = ("rigid", "flexible")

#: SI value = user value x this factor, by unit
_SCALE = {"mm": M_PER_MM, "mm/s": M_PER_MM}


@dataclass(frozen=True)
class Key:
    """One scene key.

    Attributes
    ----------
    section : str
        Its table (``""``: top level).
    name : str
        The key as written in the file, unit in the name (``increment_mm``).
    field : str or None
        The SI field of the section's dataclass it sets (``increment_m``); None for keys that
        describe the channel or choose defaults rather than set one field.
    unit : str
        The user unit (``"mm"``, ``"mm/s"``, ``"s"``, ``"N/m"``, ...; ``"1"`` dimensionless,
        ``""`` for text, flags and lists of mixed meaning).
    types : tuple of type
        The TOML value types accepted.
    default : object
        Default in user units; None: none, or it depends (the preset, the channel).
    check : str, tuple or None
        ``"positive"`` (> 0), ``"nonneg"`` (>= 0), ``"fraction"`` (0 < x < 1), a tuple of the
        allowed values, or None.
    doc : str
        What it means (one line, for the docs table and the errors).
    """

    section: str
    name: str
    field: str | None
    unit: str
    types: tuple
    default: Any
    check: Any
    doc: str

    @property
    def dotted(self) -> str:
        """``section.name`` (or ``name`` at top level)."""
        return f"{self.section}.{self.name}" if self.section else self.name

    @property
    def scale(self) -> float:
        """SI value per user value."""
        return _SCALE.get(self.unit, 1.0)

    def to_si(self, value):
        """User value -> SI (numbers and lists of numbers; other values unchanged)."""
        if self.scale == 1.0 or value is None or isinstance(value, bool):
            return value
        if isinstance(value, list | tuple | np.ndarray):
            return tuple(float(v) * self.scale for v in value)
        return float(value) * self.scale

    def from_si(self, value):
        """SI value -> user units."""
        if self.scale == 1.0 or value is None or isinstance(value, bool):
            return value
        if isinstance(value, list | tuple | np.ndarray):
            return [float(v) / self.scale for v in value]
        return float(value) / self.scale

    def problem(self, value) -> str | None:
        """What is wrong with a user-unit value (None if nothing); checks type and range."""
        return value_problem(value, self.types, self.check)


def value_problem(value, types: tuple, check) -> str | None:
    """What is wrong with ``value`` for a key of ``types`` and ``check`` (None if nothing)."""
    if isinstance(value, bool) and bool not in types:
        return f"must be {type_words(types)}"
    if not isinstance(value, types):
        return f"must be {type_words(types)}"
    if isinstance(value, float) and not math.isfinite(value):
        return "must be a finite number"
    if isinstance(check, tuple):
        return None if value in check else f"choose one of {', '.join(check)}"
    if isinstance(value, bool) or not isinstance(value, NUM):
        return None
    if check == "positive" and not value > 0:
        return "must be > 0"
    if check == "nonneg" and not value >= 0:
        return "must be >= 0"
    if check == "fraction" and not 0 < value < 1:
        return "must be between 0 and 1 (exclusive)"
    return None


def _k(section, name, field, unit, types, default, check, doc) -> Key:
    return Key(section, name, field, unit, types, default, check, doc)


#: every key of a scene file, by section, in the order the docs list them
KEYS: tuple[Key, ...] = (
    _k("", "name", None, "", (str,), None, None, "scene name (default: the file stem)"),
    _k("", "description", "description", "", (str,), "", None, "free text"),
    # ---- channel (describes a geometry object: no SI fields)
    _k("channel", "applicator", None, "", (str,), None, None,
       "shipped applicator name (ring26x60, ...) or path to an applicator file or folder "
       "(relative to the scene file)"),
    _k("channel", "channel", None, "", (str,), "ring", None, "the applicator's channel"),
    _k("channel", "kind", None, "", (str,), None, CHANNEL_KINDS,
       "analytic channel (from the origin heading +x, bends in the x-y plane) or inline points"),
    _k("channel", "length_mm", None, "mm", NUM, None, "positive", "straight: its length"),
    _k("channel", "radius_mm", None, "mm", NUM, None, "positive",
       "arc, s-curve, helix: radius of the bends"),
    _k("channel", "angle_deg", None, "deg", NUM, None, "positive",
       "arc (default 180), s-curve (each bend, default 90), helix (default 360): angle"),
    _k("channel", "pitch_mm", None, "mm", NUM, None, "nonneg", "helix: rise per turn"),
    _k("channel", "straight_mm", None, "mm", NUM, 0.0, "nonneg", "straight entry before the bend"),
    _k("channel", "exit_mm", None, "mm", NUM, 0.0, "nonneg", "straight exit after the bend(s)"),
    _k("channel", "centreline_mm", None, "mm", (list,), None, None,
       "points: [[x, y, z], ...] proximal -> distal"),
    _k("channel", "s_ref_mm", None, "mm", NUM, None, "nonneg",
       "arc length of the source centre at relative position 0 (default: length - 5 mm)"),
    _k("channel", "step_mm", None, "mm", NUM, None, "positive", "unused (kept for old files)"),
    _k("channel", "lumen", None, "", (str,), None, LUMEN_KINDS,
       "cross-section (required for analytic channels; replaces an applicator channel's)"),
    _k("channel", "r_b_mm", None, "mm", (*NUM, list), None, "positive",
       "lumen radius (stepped: one per segment)"),
    _k("channel", "r_a_mm", None, "mm", (*NUM, list), None, "positive",
       "start of the contact transition zone (default r_b - 0.1)"),
    _k("channel", "flat_mm", None, "mm", (*NUM, list), None, "nonneg",
       "u: the flat side's distance from the centreline; at or beyond r_b it does not cut the "
       "circle (stepped: one per segment, 0 = no flat)"),
    _k("channel", "flat_towards", None, "", (str,), "bend_outside", FLAT_TOWARDS,
       "u, stepped: which way the flat faces: the outside of the bend, or fixed in the "
       "applicator's frame (needs its ring frame: an applicator channel or an arc)"),
    _k("channel", "lumen_source", None, "", (str,), None, None,
       "where the lumen's dimensions come from (a citation, a measurement) or 'assumed'"),
    _k("channel", "u_start_mm", None, "mm", NUM, None, None, "u: where the flat side starts"),
    _k("channel", "u_end_mm", None, "mm", NUM, None, None, "u: where the flat side ends"),
    _k("channel", "s_breaks_mm", None, "mm", (list,), None, None,
       "stepped: arc lengths where the cross-section changes (k-1 for k segments)"),
    _k("channel", "measured_path_mm", None, "mm", (list,), None, None,
       "points: measured source path [[x, y, z], ...], most distal first"),
    _k("channel", "measured_step_mm", None, "mm", NUM, None, "positive",
       "points: spacing of the measured path"),
    # ---- instrument
    _k("instrument", "preset", None, "", (str,), "flexitron", PRESETS,
       "instrument preset (Flexitron and catheter: the paper's Table 1; microselectron: "
       "mHDR-v2 geometry, Flexitron mechanics assumed)"),
    _k("instrument", "length_mm", None, "mm", NUM, None, "positive",
       "instrument length (default the preset's: 725.6 mm Flexitron, 725.5 mm microselectron, "
       "120 mm catheter)"),
    _k("instrument", "real_mass", None, "", (bool,), False, None,
       "real masses instead of the paper's scaled ones"),
    _k("instrument", "centre_from_tip_mm", "centre_from_tip_m", "mm", NUM, None, "nonneg",
       "distance from the distal tip to the source's centre of activity"),
    _k("instrument", "sections", None, "", (list,), None, None,
       "a custom instrument: [[instrument.sections]] tables, tip first"),
    # ---- a custom instrument section
    _k("section", "name", "name", "", (str,), None, None, "section label"),
    _k("section", "length_mm", "length_m", "mm", NUM, None, "positive", "section length"),
    _k("section", "r_o_mm", "r_o_m", "mm", NUM, None, "positive", "outer radius"),
    _k("section", "ei_nm2", "ei_nm2", "N m^2", NUM, None, "positive", "bending stiffness EI"),
    _k("section", "gj_nm2", "gj_nm2", "N m^2", NUM, None, "positive", "torsional stiffness GJ"),
    _k("section", "mass_per_length_kg_m", "mass_per_length_kg_m", "kg/m", NUM, None, "positive",
       "mass per length"),
    _k("section", "element_length_mm", "element_length_m", "mm", NUM, None, "positive",
       "link length (a rigid section is one link)"),
    _k("section", "rigid", "rigid", "", (bool,), False, None, "a rigid section (the capsule)"),
    # ---- discretisation
    _k("discretisation", "element_length_mm", None, "mm", (*NUM, dict), None, "positive",
       "link length of every flexible section, or a table per section {thin = 3.0, thick = 10.0}"),
    # ---- effects
    _k("effects", "torsion", "torsion", "", (bool,), False, None, "twist DOF per node"),
    _k("effects", "contact", "contact", "", (bool,), True, None, "wall contact"),
    _k("effects", "friction", "friction", "", (str,), "stribeck", FRICTION_LAWS, "friction law"),
    _k("effects", "wall_damping", "wall_damping", "", (bool,), False, None, "wall damping"),
    _k("effects", "inertia", "inertia", "", (bool,), False, None,
       "inertia (the dynamic solver switches it on)"),
    _k("effects", "gravity", None, "", (bool,), False, None, "gravity"),
    _k("effects", "gravity_m_s2", "gravity_m_s2", "m/s^2", (list,), None, None,
       "gravity vector in the channel's frame (default [0, 9.80665, 0]: posterior in DICOM "
       "patient coordinates, supine patient)"),
    # ---- contact (defaults: the preset's, the paper's Table 1)
    _k("contact", "stiffness_n_m", "stiffness_n_m", "N/m", NUM, 1.0e5, "positive",
       "wall stiffness k per contact point"),
    _k("contact", "damping_ns_m", "damping_ns_m", "N s/m", NUM, 10.0, "nonneg",
       "wall damping c_w (with effects.wall_damping)"),
    _k("contact", "mu_s", "mu_s", "1", NUM, 0.25, "nonneg", "static friction coefficient"),
    _k("contact", "mu_k", "mu_k", "1", NUM, 0.20, "nonneg",
       "kinetic friction coefficient (<= mu_s)"),
    _k("contact", "v_brk_mm_s", "v_brk_m_s", "mm/s", NUM, 1.0, "positive", "breakaway velocity"),
    _k("contact", "transition_mm", "transition_m", "mm", NUM, None, "positive",
       "contact transition width (default from the lumen: r_b - r_a)"),
    _k("contact", "transition_max_fraction", "transition_max_fraction", "1", NUM, 0.2, "fraction",
       "the transition zone is at most this fraction of the clearance"),
    _k("contact", "friction_v_reg_mm_s", "friction_v_reg_m_s", "mm/s", NUM, None, "positive",
       "friction regularisation velocity (default v_brk / 10)"),
    _k("contact", "friction_slip_min_m", "friction_slip_min_m", "m", NUM, 1.0e-7, "nonneg",
       "smallest slip per step the friction regularisation acts over"),
    _k("contact", "stiffness_per_length", "stiffness_per_length", "", (bool,), False, None,
       "k and c_w per 3 mm of cable instead of per contact point (for convergence studies)"),
    # ---- motion
    _k("motion", "kind", "kind", "", (str,), "constant", MOTION_KINDS, "input motion"),
    _k("motion", "advances_mm", "advances_m", "mm", (list,), None, None,
       "cable advances to report (centreline arc length of the source centre if the cable "
       "followed the centreline); wins over step_mm/span_mm"),
    _k("motion", "step_mm", None, "mm", NUM, None, "positive",
       "spacing of the default advances (default: the measured path's, else 1 mm)"),
    _k("motion", "span_mm", None, "mm", NUM, None, "nonneg",
       "extent of the default advances back from s_ref (default: the measured path's, else 60)"),
    _k("motion", "speed_mm_s", "speed_m_s", "mm/s", NUM, None, "positive",
       "input speed (default the preset's: 500 source cables, 100 catheter)"),
    _k("motion", "start_mm", "start_m", "mm", NUM, None, None,
       "advance at which the run starts (default: the tip at the channel entry)"),
    _k("motion", "dwell_s", "dwell_s", "s", NUM, 0.0, "nonneg", "pause per dwell (stepwise)"),
    _k("motion", "backward", "backward", "", (bool,), False, None,
       "stepwise from the most distal dwell backwards"),
    # ---- solver
    _k("solver", "kind", "kind", "", (str,), "quasistatic", SOLVER_KINDS, "solver"),
    _k("solver", "integrator", "integrator", "", (str,), "backward_euler", INTEGRATORS,
       "time integrator of the dynamic solver"),
    _k("solver", "increment_mm", "increment_m", "mm", NUM, 1.0, "positive",
       "input increment per quasi-static load step"),
    _k("solver", "time_step_s", "time_step_s", "s", NUM, 1.0e-3, "positive",
       "time step of the dynamic solver"),
    _k("solver", "tol", "tol", "1", NUM, 1.0e-8, "positive",
       "Newton tolerance (relative to EI / l^2)"),
    _k("solver", "max_iter", "max_iter", "", (int,), 50, "positive", "Newton iterations per step"),
    _k("solver", "stabilisation", "stabilisation", "N s/m", NUM, 0.0, "nonneg",
       "viscous tether on every quasi-static step (0: only as the fallback)"),
    _k("solver", "jam_force_n", "jam_force_n", "N", NUM, 50.0, "positive",
       "push force above which the run is reported as jammed"),
    _k("solver", "jam_length_mm", "jam_length_m", "mm", NUM, 20.0, "positive",
       "input length without source progress after which the run is jammed"),
    _k("solver", "axial_stiffness_n", "axial_stiffness_n", "N", NUM, 1.0e6, "positive",
       "inextensibility penalty EA"),
    _k("solver", "approach_mm", "approach_m", "mm", NUM, 20.0, "positive",
       "straight cable modelled in front of the channel entry"),
    _k("solver", "contact_bow_fraction", "contact_bow_fraction", "1", NUM, 0.1, "positive",
       "contact samples per link: a link's bow between samples <= this fraction of the clearance"),
    # ---- outputs
    _k("outputs", "trajectory", "trajectory", "", (bool,), False, None,
       "keep every step (ringqa simulate writes trajectory.h5)"),
    # ---- model (the discretisation: a second, independent engine)
    _k("model", "formulation", "formulation", "", (str,), "rigid", FORMULATIONS,
       "rigid links with hinge springs (the paper's rigid model) or flexible beam elements "
       "(cubic Hermite, nodal positions and tangents; quasi-static only)"),
)  # fmt: skip

#: the tables of a scene file (``section`` is a custom instrument section, inside [instrument])
SECTIONS = ("", "channel", "instrument", "discretisation", "effects", "contact", "motion",
            "solver", "outputs", "model")  # fmt: skip

_BY_NAME = {(k.section, k.name): k for k in KEYS}
_BY_FIELD = {(k.section, k.field): k for k in KEYS if k.field}


def key(section: str, name: str) -> Key:
    """The key ``name`` of ``section``."""
    return _BY_NAME[(section, name)]


def section_keys(section: str) -> tuple[Key, ...]:
    """The keys of a section, in order."""
    return tuple(k for k in KEYS if k.section == section)


def field_key(section: str, field: str) -> Key:
    """The key that sets the SI field ``field`` of ``section``'s dataclass."""
    return _BY_FIELD[(section, field)]


def default_si(section: str, field: str):
    """The SI default of a dataclass field, from its key."""
    k = field_key(section, field)
    return k.to_si(k.default)


def type_words(types) -> str:
    """``(int, float)`` -> ``"a number"`` (for messages)."""
    names = {int: "an integer", float: "a number", str: "a string", bool: "true or false"}
    names.update({list: "a list", dict: "a table"})
    words = [names[t] for t in types if t in names]
    if float in types and int in types:
        words.remove("an integer")
    return " or ".join(dict.fromkeys(words))


def check_fields(section: str, obj, fields: tuple[str, ...] | None = None) -> None:
    """Validate a section dataclass's SI fields against their keys (``__post_init__``).

    Raises
    ------
    SceneError
        ``section.key: <problem>, got <value in user units> <unit>``.
    """
    for k in section_keys(section):
        if not k.field or (fields is not None and k.field not in fields):
            continue
        value = getattr(obj, k.field)
        if value is None or isinstance(value, tuple | list | np.ndarray):
            continue
        if isinstance(value, bool | str) or not isinstance(value, NUM):
            user = value
        else:
            user = k.from_si(value)
            whole = int in k.types and float not in k.types and user == int(user)
            user = int(user) if whole else float(user)
        problem = k.problem(user)
        if problem:
            unit = f" {k.unit}" if k.unit not in ("", "1") else ""
            shown = f"{user:g}" if isinstance(user, float) else repr(user)
            raise SceneError(f"{k.dotted}: {problem}, got {shown}{unit}")


def _toml(value) -> str:
    """A default as it is written in a TOML file."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    return f"{value:g}"


def markdown_table() -> str:
    """The keys as a Markdown table (``data/scenes/README.md``: generated, kept equal by a test)."""
    rows = ["| key | unit | default | allowed | meaning |", "|---|---|---|---|---|"]
    for k in KEYS:
        if k.section == "section":
            name = f"instrument.sections[].{k.name}"
        else:
            name = k.dotted
        default = "" if k.default is None else f"`{_toml(k.default)}`"
        if isinstance(k.check, tuple):
            allowed = ", ".join(f"`{c}`" for c in k.check)
        else:
            allowed = {"positive": "> 0", "nonneg": ">= 0", "fraction": "0 .. 1"}.get(k.check, "")
        rows.append(f"| `{name}` | {k.unit} | {default} | {allowed} | {k.doc} |")
    return "\n".join(rows) + "\n"
