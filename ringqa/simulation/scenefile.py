"""Scene files: TOML in millimetres/degrees/seconds in, a validated SI :class:`Scene` out.

A scene file has the sections ``[channel]``, ``[instrument]``, ``[discretisation]``,
``[effects]``, ``[contact]``, ``[motion]``, ``[solver]`` and ``[outputs]`` (all optional except
the channel) plus top-level ``name`` and ``description``. Keys carry their unit in the name
(``increment_mm``, ``speed_mm_s``, ``time_step_s``); this module is the ONE place where they are
converted to SI (with :mod:`ringqa.units`). Every error names the file, the dotted key and the fix.
``data/scenes/README.md`` documents every key; :data:`SCHEMA` is the machine-readable version.

The channel is either an applicator channel::

    [channel]
    applicator = "ring26x60"     # shipped name or path to an applicator file/folder
    channel = "ring"

or an analytic channel for validation scenes (``kind`` = ``"straight"``, ``"arc"``, ``"helix"``,
``"s-curve"``) or an inline centreline (``kind = "points"``, ``centreline_mm = [[x, y, z], ...]``),
with a lumen (``lumen = "circular" | "u" | "stepped"``, ``r_b_mm``, ``r_a_mm``, ``flat_mm``,
``s_breaks_mm``). Lumen keys given with an applicator replace that channel's lumen.

Overrides (``--set KEY=VALUE`` on the command line, ``overrides=`` here) are dotted keys in the
same user units; string values are parsed as TOML values (``0.5``, ``true``, ``[1, 2]``,
``{thin = 2.0, thick = 5.0}``) and fall back to plain strings (``flexitron``).
"""

from __future__ import annotations

import copy
import math
import tomllib
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.errors import RingQAError, SceneError
from ringqa.simulation.instruments import CABLE_PRESETS, CONTACT_PRESETS, cable_preset
from ringqa.simulation.scene import (
    FRICTION_LAWS,
    INTEGRATORS,
    MOTION_KINDS,
    SOLVER_KINDS,
    CableSection,
    ContactParams,
    Effects,
    Instrument,
    Motion,
    Outputs,
    Scene,
    SolverSettings,
)
from ringqa.units import deg_to_rad, m_to_mm, mm_to_m

CHANNEL_KINDS = ("applicator", "straight", "arc", "helix", "s-curve", "points")
LUMEN_KINDS = ("circular", "u", "stepped")
STANDARD_GRAVITY_M_S2 = 9.80665
DEFAULT_STEP_MM = 1.0  # dwell spacing when the channel has no measured path (paper: 1 mm)
DEFAULT_SPAN_MM = 60.0  # length covered by default dwells without a measured path (ring: 60 mm)
ANALYTIC_TIP_GAP_MM = 5.0  # analytic channels: s_ref = length - 5 mm (as the 1st ring marker)
_POINT_SPACING_MM = 0.25  # sampling of analytic centrelines handed to Centreline.from_points

_NUM = (int, float)
_ANY_NUM_OR_TABLE = "number-or-table"

# section -> key -> (accepted types, default or None, allowed values / "positive" / "nonneg" / None)
SCHEMA: dict[str, dict[str, tuple[Any, Any, Any]]] = {
    "": {"name": ((str,), None, None), "description": ((str,), "", None)},
    "channel": {
        "applicator": ((str,), None, None),
        "channel": ((str,), "ring", None),
        "kind": ((str,), None, CHANNEL_KINDS),
        "length_mm": (_NUM, None, "positive"),
        "radius_mm": (_NUM, None, "positive"),
        "angle_deg": (_NUM, None, "positive"),
        "pitch_mm": (_NUM, None, "nonneg"),
        "straight_mm": (_NUM, 0.0, "nonneg"),
        "exit_mm": (_NUM, 0.0, "nonneg"),
        "centreline_mm": ((list,), None, None),
        "s_ref_mm": (_NUM, None, "nonneg"),
        "step_mm": (_NUM, None, "positive"),
        "lumen": ((str,), None, LUMEN_KINDS),
        "r_b_mm": ((*_NUM, list), None, "positive"),
        "r_a_mm": ((*_NUM, list), None, "positive"),
        "flat_mm": ((*_NUM, list), None, "nonneg"),
        "u_start_mm": (_NUM, None, None),
        "u_end_mm": (_NUM, None, None),
        "s_breaks_mm": ((list,), None, None),
        "measured_path_mm": ((list,), None, None),
        "measured_step_mm": (_NUM, None, "positive"),
    },
    "instrument": {
        "preset": ((str,), "flexitron", tuple(CABLE_PRESETS)),
        "length_mm": (_NUM, None, "positive"),
        "real_mass": ((bool,), False, None),
        "centre_from_tip_mm": (_NUM, None, "nonneg"),
        "sections": ((list,), None, None),
    },
    "discretisation": {"element_length_mm": ((*_NUM, dict), None, _ANY_NUM_OR_TABLE)},
    "effects": {
        "torsion": ((bool,), False, None),
        "contact": ((bool,), True, None),
        "friction": ((str,), "stribeck", FRICTION_LAWS),
        "wall_damping": ((bool,), False, None),
        "inertia": ((bool,), False, None),
        "gravity": ((bool,), False, None),
        "gravity_m_s2": ((list,), None, None),
    },
    "contact": {
        "stiffness_n_m": (_NUM, None, "positive"),
        "damping_ns_m": (_NUM, None, "nonneg"),
        "mu_s": (_NUM, None, "nonneg"),
        "mu_k": (_NUM, None, "nonneg"),
        "v_brk_mm_s": (_NUM, None, "positive"),
        "transition_mm": (_NUM, None, "positive"),
        "transition_max_fraction": (_NUM, None, "positive"),
        "friction_v_reg_mm_s": (_NUM, None, "positive"),
        "friction_slip_min_m": (_NUM, None, "nonneg"),
        "stiffness_per_length": ((bool,), None, None),
    },
    "motion": {
        "kind": ((str,), "constant", MOTION_KINDS),
        "advances_mm": ((list,), None, None),
        "step_mm": (_NUM, None, "positive"),
        "span_mm": (_NUM, None, "nonneg"),
        "speed_mm_s": (_NUM, None, "positive"),
        "start_mm": (_NUM, None, None),
        "dwell_s": (_NUM, 0.0, "nonneg"),
        "backward": ((bool,), False, None),
    },
    "solver": {
        "kind": ((str,), "quasistatic", SOLVER_KINDS),
        "integrator": ((str,), "backward_euler", INTEGRATORS),
        "increment_mm": (_NUM, 1.0, "positive"),
        "time_step_s": (_NUM, 1.0e-3, "positive"),
        "tol": (_NUM, 1.0e-8, "positive"),
        "max_iter": ((int,), 50, "positive"),
        "stabilisation": (_NUM, 0.0, "nonneg"),
        "jam_force_n": (_NUM, 50.0, "positive"),
        "jam_length_mm": (_NUM, 20.0, "positive"),
        "axial_stiffness_n": (_NUM, None, "positive"),
        "approach_mm": (_NUM, None, "nonneg"),
        "contact_bow_fraction": (_NUM, None, "positive"),
    },
    "outputs": {"trajectory": ((bool,), False, None)},
}

# Engine settings that exist only when the engine defines the field (user key -> SI field, unit).
EXTRA_FIELDS = {
    "contact": {
        "transition_max_fraction": ("transition_max_fraction", "1"),
        "friction_v_reg_mm_s": ("friction_v_reg_m_s", "mm"),
        "friction_slip_min_m": ("friction_slip_min_m", "1"),
        "stiffness_per_length": ("stiffness_per_length", "bool"),
    },
    "solver": {
        "axial_stiffness_n": ("axial_stiffness_n", "1"),
        "approach_mm": ("approach_m", "mm"),
        "contact_bow_fraction": ("contact_bow_fraction", "1"),
    },
}


def _extra_in(ck: _Checker, section: str, obj):
    """Apply the EXTRA_FIELDS keys given in ``section`` to the dataclass ``obj``."""
    sec = ck.section(section)
    changes = {}
    for key, (fname, unit) in EXTRA_FIELDS[section].items():
        if key not in sec:
            continue
        if not hasattr(obj, fname):
            raise ck.fail(f"{section}.{key}", "not supported by this engine", "remove the key")
        if unit == "bool":
            changes[fname] = bool(ck.value(section, key, sec=sec))
            continue
        val = float(ck.value(section, key, sec=sec))
        changes[fname] = mm_to_m(val) if unit == "mm" else val
    return replace(obj, **changes) if changes else obj


def _extra_out(obj, section: str) -> dict:
    out = {}
    for key, (fname, unit) in EXTRA_FIELDS[section].items():
        val = getattr(obj, fname, None)
        if val is not None:
            out[key] = bool(val) if unit == "bool" else (m_to_mm(val) if unit == "mm" else val)
    return out


SECTION_KEYS = {
    "name": (str,),
    "length_mm": _NUM,
    "r_o_mm": _NUM,
    "ei_nm2": _NUM,
    "gj_nm2": _NUM,
    "mass_per_length_kg_m": _NUM,
    "element_length_mm": _NUM,
    "rigid": (bool,),
}


# ------------------------------------------------------------------------------------------------
# reading and overriding
# ------------------------------------------------------------------------------------------------
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
    try:
        with open(p, "rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{p}: not valid TOML: {exc} (fix the syntax there)") from None


def parse_value(text: str) -> Any:
    """A ``--set`` value: a TOML value if it parses as one, else the plain string."""
    if not isinstance(text, str):
        return text
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
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


def apply_overrides(data: Mapping, overrides: Mapping[str, Any] | None, origin: str = "") -> dict:
    """A deep copy of ``data`` with dotted-key overrides applied (values parsed from strings)."""
    out = copy.deepcopy(dict(data))
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


# ------------------------------------------------------------------------------------------------
# validation helpers
# ------------------------------------------------------------------------------------------------
class _Checker:
    def __init__(self, data: dict, origin: str) -> None:
        self.data = data
        self.origin = origin  # "path: " or ""

    def fail(self, key: str, problem: str, fix: str) -> SceneError:
        return SceneError(f"{self.origin}{key}: {problem} ({fix})")

    def section(self, name: str) -> dict:
        sec = self.data.get(name, {})
        if not isinstance(sec, dict):
            raise self.fail(name, "must be a table", f"write it as [{name}] with keys below it")
        allowed = SCHEMA[name]
        unknown = sorted(set(sec) - set(allowed))
        if unknown:
            raise self.fail(
                f"{name}.{unknown[0]}",
                "unknown key",
                f"keys allowed in [{name}]: {', '.join(allowed)}",
            )
        return sec

    def value(self, section: str, key: str, default: Any = ..., sec: dict | None = None):
        types, schema_default, allowed = SCHEMA[section][key]
        dotted = f"{section}.{key}" if section else key
        src = self.data if not section else (sec if sec is not None else self.section(section))
        if key not in src:
            return schema_default if default is ... else default
        val = src[key]
        return self.check(dotted, val, types, allowed)

    def check(self, dotted: str, val, types, allowed):
        if isinstance(val, bool) and bool not in types:
            raise self.fail(dotted, f"got {val!r}", f"must be {_type_words(types)}")
        if not isinstance(val, types):
            raise self.fail(dotted, f"got {val!r}", f"must be {_type_words(types)}")
        if isinstance(val, float) and not math.isfinite(val):
            raise self.fail(dotted, f"got {val!r}", "must be a finite number")
        if allowed == "positive" and isinstance(val, _NUM) and not val > 0:
            raise self.fail(dotted, f"got {val!r}", "must be > 0")
        if allowed == "nonneg" and isinstance(val, _NUM) and not val >= 0:
            raise self.fail(dotted, f"got {val!r}", "must be >= 0")
        if isinstance(allowed, tuple) and val not in allowed:
            raise self.fail(dotted, f"got {val!r}", f"choose one of {', '.join(allowed)}")
        if isinstance(val, list) and allowed == "positive":
            for i, v in enumerate(val):
                self.check(f"{dotted}[{i}]", v, _NUM, "positive")
        return float(val) if isinstance(val, int) and float in types and int not in types else val

    def numbers(self, dotted: str, val, ndim: int = 1, positive: bool = False) -> np.ndarray:
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


def _type_words(types) -> str:
    names = {int: "an integer", float: "a number", str: "a string", bool: "true or false"}
    names.update({list: "a list", dict: "a table"})
    words = [names[t] for t in types if t in names]
    if float in types and int in types:
        words.remove("an integer")
    return " or ".join(dict.fromkeys(words))


# ------------------------------------------------------------------------------------------------
# channel
# ------------------------------------------------------------------------------------------------
def _arc(start, tangent, normal, radius, angle, n):
    """Points of a planar arc from ``start`` with unit ``tangent``, bending towards ``normal``."""
    phi = np.linspace(0.0, angle, n)
    centre = start + radius * normal
    pts = centre - radius * np.outer(np.cos(phi), normal) + radius * np.outer(np.sin(phi), tangent)
    end_t = np.cos(angle) * tangent + np.sin(angle) * normal
    end_n = np.cos(angle) * normal - np.sin(angle) * tangent
    return pts, end_t, end_n


def _line(start, tangent, length, n):
    return start + np.outer(np.linspace(0.0, length, n), tangent)


def _count(length_mm: float) -> int:
    return max(3, math.ceil(length_mm / _POINT_SPACING_MM) + 1)


def analytic_centreline_mm(spec: Mapping[str, Any]) -> np.ndarray:
    """Centreline points (mm), proximal -> distal, for an analytic channel spec.

    Shapes (all start at the origin heading along +x; the bends lie in the x-y plane, the helix
    axis is +z):

    - ``straight``: ``length_mm``.
    - ``arc``: ``straight_mm`` approach, then an arc of ``radius_mm`` over ``angle_deg``
      (default 180), then ``exit_mm`` straight.
    - ``helix``: ``straight_mm`` approach, then a helix of ``radius_mm`` and ``pitch_mm`` (rise
      per turn) over ``angle_deg`` (default 360).
    - ``s-curve``: ``straight_mm``, an arc of ``radius_mm`` over ``angle_deg`` (default 90)
      bending left, the same arc bending right, then ``exit_mm``.
    """
    kind = spec["kind"]
    x, y = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    o = np.zeros(3)
    if kind == "straight":
        return _line(o, x, spec["length_mm"], _count(spec["length_mm"]))
    r = spec["radius_mm"]
    straight = spec.get("straight_mm", 0.0)
    parts = [_line(o, x, straight, _count(straight))] if straight > 0 else [o[None, :]]
    start = parts[-1][-1]
    if kind == "arc":
        ang = deg_to_rad(spec.get("angle_deg") or 180.0)
        pts, t, _ = _arc(start, x, y, r, ang, _count(r * ang))
        parts.append(pts[1:])
        exit_mm = spec.get("exit_mm", 0.0)
        if exit_mm > 0:
            parts.append(_line(pts[-1], t, exit_mm, _count(exit_mm))[1:])
    elif kind == "s-curve":
        ang = deg_to_rad(spec.get("angle_deg") or 90.0)
        pts, t, nrm = _arc(start, x, y, r, ang, _count(r * ang))
        parts.append(pts[1:])
        pts2, t2, _ = _arc(pts[-1], t, -nrm, r, ang, _count(r * ang))
        parts.append(pts2[1:])
        exit_mm = spec.get("exit_mm", 0.0)
        if exit_mm > 0:
            parts.append(_line(pts2[-1], t2, exit_mm, _count(exit_mm))[1:])
    elif kind == "helix":
        ang = deg_to_rad(spec.get("angle_deg") or 360.0)
        pitch = spec.get("pitch_mm", 0.0)
        c = pitch / (2.0 * math.pi)
        # helix tangent at phi = 0 is (r, 0, c)/sqrt(r^2+c^2): tilt the approach to match it
        n = _count(math.hypot(r, c) * ang)
        phi = np.linspace(0.0, ang, n)
        helix = np.column_stack([r * np.sin(phi), r * (1.0 - np.cos(phi)), c * phi])
        t0 = np.array([r, 0.0, c]) / math.hypot(r, c)
        if straight > 0:
            approach = _line(o, t0, straight, _count(straight))
            parts = [approach, approach[-1] + helix[1:]]
        else:
            parts = [helix]
    else:  # pragma: no cover - guarded by the schema
        raise ValueError(kind)
    return np.vstack(parts)


def _lumen(ck: _Checker, sec: dict, required: bool):
    try:
        return _lumen_inner(ck, sec, required)
    except SceneError:
        raise
    except RingQAError as exc:
        raise ck.fail("channel.lumen", str(exc), "check r_b_mm, r_a_mm, flat_mm") from None


def _lumen_inner(ck: _Checker, sec: dict, required: bool):
    from ringqa.geometry import Lumen

    kind = ck.value("channel", "lumen", sec=sec)
    if kind is None:
        if not required and not any(k in sec for k in ("r_b_mm", "r_a_mm", "flat_mm")):
            return None
        kind = "circular"
    r_b = ck.value("channel", "r_b_mm", sec=sec)
    r_a = ck.value("channel", "r_a_mm", sec=sec)
    if r_b is None:
        raise ck.fail("channel.r_b_mm", "missing", "give the lumen radius, e.g. r_b_mm = 1.5")
    if kind == "stepped":
        breaks = ck.value("channel", "s_breaks_mm", sec=sec)
        if breaks is None:
            raise ck.fail(
                "channel.s_breaks_mm",
                "missing for lumen = 'stepped'",
                "give the arc lengths (mm) where the radius changes",
            )
        s_b = ck.numbers("channel.s_breaks_mm", breaks)
        rb = ck.numbers("channel.r_b_mm", r_b if isinstance(r_b, list) else [r_b], positive=True)
        ra_in = r_a if r_a is not None else [x - 0.1 for x in np.atleast_1d(rb)]
        ra = ck.numbers("channel.r_a_mm", ra_in if isinstance(ra_in, list) else [ra_in])
        if rb.size != s_b.size + 1 or ra.size != rb.size:
            raise ck.fail(
                "channel.r_b_mm",
                f"{rb.size} radii for {s_b.size} breaks",
                "a stepped lumen needs one more radius (r_b_mm and r_a_mm) than s_breaks_mm",
            )
        flat_in = ck.value("channel", "flat_mm", sec=sec)
        if flat_in is None:
            return Lumen.stepped(mm_to_m(s_b), mm_to_m(rb), mm_to_m(ra))
        flat = ck.numbers("channel.flat_mm", flat_in if isinstance(flat_in, list) else [flat_in])
        if flat.size != rb.size:
            raise ck.fail("channel.flat_mm", "wrong length", "one value per segment (0 = no flat)")
        seg_s = np.concatenate([[-np.inf], mm_to_m(s_b), [np.inf]])
        seg_flat = np.where(flat > 0, mm_to_m(flat), np.inf)
        return Lumen(seg_s, mm_to_m(rb), mm_to_m(ra), seg_flat)
    if isinstance(r_b, list) or isinstance(r_a, list):
        raise ck.fail("channel.r_b_mm", "a list", "lists of radii need lumen = 'stepped'")
    r_a = r_b - 0.1 if r_a is None else r_a
    if not 0 < r_a <= r_b:
        raise ck.fail("channel.r_a_mm", f"got {r_a}", f"must be in (0, r_b_mm = {r_b}]")
    if kind == "u":
        flat = ck.value("channel", "flat_mm", sec=sec)
        if flat is None:
            raise ck.fail(
                "channel.flat_mm",
                "missing for lumen = 'u'",
                "give the flat side's distance from the centreline (mm), e.g. flat_mm = 1.2",
            )
        if isinstance(flat, list) or not flat > 0:
            raise ck.fail("channel.flat_mm", f"got {flat!r}", "give one positive distance (mm)")
        start = ck.value("channel", "u_start_mm", sec=sec)
        end = ck.value("channel", "u_end_mm", sec=sec)
        return Lumen.u_shaped(
            mm_to_m(r_b),
            mm_to_m(r_a),
            mm_to_m(flat),
            -np.inf if start is None else mm_to_m(start),
            np.inf if end is None else mm_to_m(end),
        )
    return Lumen.circular(mm_to_m(r_b), mm_to_m(r_a))


def build_channel(ck: _Checker):
    """The :class:`ringqa.geometry.Channel` a scene's ``[channel]`` table describes."""
    sec = ck.section("channel")
    if not sec:
        raise ck.fail(
            "channel",
            "missing",
            "add a [channel] table with applicator = 'ring26x60' or an analytic kind = 'arc'",
        )
    for key in sec:
        ck.value("channel", key, sec=sec)  # type/range check every key given
    kind = sec.get("kind", "applicator" if "applicator" in sec else None)
    if kind is None:
        raise ck.fail(
            "channel.applicator",
            "missing",
            "give applicator = 'ring26x60' (or a file) or an analytic kind = 'arc'",
        )
    if kind == "applicator":
        return _applicator_channel(ck, sec)
    from ringqa.geometry import Centreline, Channel

    if kind == "points":
        if "centreline_mm" not in sec:
            raise ck.fail("channel.centreline_mm", "missing", "give [[x, y, z], ...] in mm")
        pts_mm = ck.numbers("channel.centreline_mm", sec["centreline_mm"], ndim=2)
    else:
        need = {"straight": ("length_mm",), "arc": ("radius_mm",), "s-curve": ("radius_mm",)}
        need["helix"] = ("radius_mm", "pitch_mm")
        for key in need[kind]:
            if key not in sec:
                raise ck.fail(f"channel.{key}", f"missing for kind = {kind!r}", "give it in mm")
        pts_mm = analytic_centreline_mm(sec)
    try:
        cl = Centreline.from_points(mm_to_m(pts_mm))
    except RingQAError as exc:
        raise ck.fail(
            "channel", f"cannot build the centreline: {exc}", "check its parameters"
        ) from None
    lumen = _lumen(ck, sec, required=True)
    length_mm = m_to_mm(cl.length_m)
    s_ref_mm = sec.get("s_ref_mm", max(length_mm - ANALYTIC_TIP_GAP_MM, 0.5 * length_mm))
    if not 0 <= s_ref_mm <= length_mm:
        raise ck.fail(
            "channel.s_ref_mm",
            f"{s_ref_mm} mm is outside the channel (length {length_mm:.2f} mm)",
            "choose an arc length inside the channel",
        )
    measured = None
    if "measured_path_mm" in sec:
        measured = mm_to_m(ck.numbers("channel.measured_path_mm", sec["measured_path_mm"], ndim=2))
        if "measured_step_mm" not in sec:
            raise ck.fail("channel.measured_step_mm", "missing", "give the measured path's step")
    return Channel(
        name=str(sec.get("channel", kind)),
        centreline=cl,
        lumen=lumen,
        s_ref_m=mm_to_m(s_ref_mm),
        measured_path_m=measured,
        measured_step_m=None if measured is None else mm_to_m(sec["measured_step_mm"]),
    )


def _applicator_channel(ck: _Checker, sec: dict):
    from ringqa.io.applicator_file import load_applicator

    name = sec.get("applicator")
    if name is None:
        raise ck.fail("channel.applicator", "missing", "give a shipped name such as 'ring26x60'")
    ref = str(name)
    if ck.origin and not Path(ref).is_absolute() and ("/" in ref or ref.endswith(".json")):
        base = Path(ck.origin.rstrip(": ")).parent  # relative paths: relative to the scene file
        if (base / ref).exists():
            ref = str(base / ref)
    try:
        app = load_applicator(ref)
    except SceneError:
        raise
    except Exception as exc:  # RingQAError from io, or a missing file
        raise ck.fail(
            "channel.applicator",
            f"cannot load {name!r}: {exc}",
            "use a shipped name (ringqa.io.applicator_file.shipped_applicators()) or a file path",
        ) from None
    chan_name = sec.get("channel", "ring")
    try:
        channel = app.channel(chan_name)
    except Exception:
        names = ", ".join(c.name for c in app.channels)
        raise ck.fail(
            "channel.channel", f"{name!r} has no channel {chan_name!r}", f"choose one of {names}"
        ) from None
    lumen = _lumen(ck, sec, required=False)
    if lumen is not None:
        channel = replace(channel, lumen=lumen)
    if "s_ref_mm" in sec:
        channel = replace(channel, s_ref_m=mm_to_m(sec["s_ref_mm"]))
    return channel


# ------------------------------------------------------------------------------------------------
# instrument, effects, contact, motion, solver
# ------------------------------------------------------------------------------------------------
def _instrument(ck: _Checker, max_advance_m: float, preset: str) -> Instrument:
    sec = ck.section("instrument")
    disc = ck.section("discretisation")
    elem = ck.value("discretisation", "element_length_mm", sec=disc)
    sections_in = ck.value("instrument", "sections", sec=sec)
    if sections_in is not None:
        inst = _custom_instrument(ck, sec, sections_in)
    else:
        inst = cable_preset(preset, real_mass=ck.value("instrument", "real_mass", sec=sec))
        if "centre_from_tip_mm" in sec:
            inst = replace(inst, centre_from_tip_m=mm_to_m(sec["centre_from_tip_mm"]))
    names = [s.name for s in inst.sections]
    if elem is not None:
        if isinstance(elem, dict):
            unknown = sorted(set(elem) - set(names))
            if unknown:
                raise ck.fail(
                    f"discretisation.element_length_mm.{unknown[0]}",
                    "unknown section",
                    f"the instrument's sections are {', '.join(names)}",
                )
            for k, v in elem.items():
                ck.check(f"discretisation.element_length_mm.{k}", v, _NUM, "positive")
            per = {k: mm_to_m(v) for k, v in elem.items()}
        else:
            per = {s.name: mm_to_m(elem) for s in inst.sections if not s.rigid}
        secs = [
            replace(s, element_length_m=per[s.name]) if s.name in per and not s.rigid else s
            for s in inst.sections
        ]
        inst = replace(inst, sections=tuple(secs))
    length = ck.value("instrument", "length_mm", sec=sec)
    # default: the preset's full length; the engine models only the part it needs (the deepest
    # tip position plus its straight approach before the entry)
    total = mm_to_m(length) if length is not None else None
    if total is not None:
        distal = sum(s.length_m for s in inst.sections[:-1])
        if total <= distal:
            raise ck.fail(
                "instrument.length_mm",
                f"{m_to_mm(total):g} mm is shorter than the distal sections "
                f"({m_to_mm(distal):g} mm)",
                "give a longer instrument",
            )
        secs = list(inst.sections)
        secs[-1] = replace(secs[-1], length_m=total - distal)
        inst = replace(inst, sections=tuple(secs))
    return inst


def _custom_instrument(ck: _Checker, sec: dict, sections_in: list) -> Instrument:
    secs = []
    for i, raw in enumerate(sections_in):
        where = f"instrument.sections[{i}]"
        if not isinstance(raw, dict):
            raise ck.fail(where, "must be a table", "write [[instrument.sections]] tables")
        unknown = sorted(set(raw) - set(SECTION_KEYS))
        if unknown:
            raise ck.fail(f"{where}.{unknown[0]}", "unknown key", f"use {', '.join(SECTION_KEYS)}")
        for key in SECTION_KEYS:
            if key not in raw and key != "rigid":
                raise ck.fail(f"{where}.{key}", "missing", "every section needs it")
        vals = {
            k: ck.check(f"{where}.{k}", raw[k], t, None if k in ("name", "rigid") else "positive")
            for k, t in SECTION_KEYS.items()
            if k in raw
        }
        secs.append(
            CableSection(
                name=vals["name"],
                length_m=mm_to_m(vals["length_mm"]),
                r_o_m=mm_to_m(vals["r_o_mm"]),
                ei_nm2=float(vals["ei_nm2"]),
                gj_nm2=float(vals["gj_nm2"]),
                mass_per_length_kg_m=float(vals["mass_per_length_kg_m"]),
                element_length_m=mm_to_m(vals["element_length_mm"]),
                rigid=bool(vals.get("rigid", False)),
            )
        )
    if not secs:
        raise ck.fail("instrument.sections", "empty", "give at least one section")
    preset = sec.get("preset")
    return Instrument(
        name=str(preset) if preset else "custom",
        sections=tuple(secs),
        centre_from_tip_m=mm_to_m(sec.get("centre_from_tip_mm", 0.0)),
        afterloader=CABLE_PRESETS[preset].afterloader if preset in CABLE_PRESETS else "",
    )


def _effects(ck: _Checker) -> Effects:
    sec = ck.section("effects")
    v = {k: ck.value("effects", k, sec=sec) for k in SCHEMA["effects"]}
    gravity = None
    if v["gravity"]:
        g = (
            v["gravity_m_s2"]
            if v["gravity_m_s2"] is not None
            else [0.0, 0.0, -STANDARD_GRAVITY_M_S2]
        )
        gravity = tuple(float(x) for x in ck.numbers("effects.gravity_m_s2", g))
        if len(gravity) != 3:
            raise ck.fail("effects.gravity_m_s2", "needs 3 components", "write [gx, gy, gz]")
    return Effects(
        torsion=v["torsion"],
        contact=v["contact"],
        friction=v["friction"],
        wall_damping=v["wall_damping"],
        inertia=v["inertia"],
        gravity_m_s2=gravity,
    )


def _contact(ck: _Checker, preset: str) -> ContactParams:
    sec = ck.section("contact")
    base = CONTACT_PRESETS.get(preset, ContactParams())
    v = {k: ck.value("contact", k, sec=sec) for k in SCHEMA["contact"]}
    out = replace(
        base,
        stiffness_n_m=float(v["stiffness_n_m"] or base.stiffness_n_m),
        damping_ns_m=float(base.damping_ns_m if v["damping_ns_m"] is None else v["damping_ns_m"]),
        mu_s=float(base.mu_s if v["mu_s"] is None else v["mu_s"]),
        mu_k=float(base.mu_k if v["mu_k"] is None else v["mu_k"]),
        v_brk_m_s=base.v_brk_m_s if v["v_brk_mm_s"] is None else mm_to_m(v["v_brk_mm_s"]),
        transition_m=None if v["transition_mm"] is None else mm_to_m(v["transition_mm"]),
    )
    out = _extra_in(ck, "contact", out)
    if out.mu_k > out.mu_s:
        raise ck.fail(
            "contact.mu_k",
            f"{out.mu_k} exceeds mu_s = {out.mu_s}",
            "the kinetic coefficient must not exceed the static (Stribeck peak) one",
        )
    return out


def default_advances_mm(channel, step_mm: float | None = None, span_mm: float | None = None):
    """Default dwell advances (mm, ascending) for a channel.

    Every ``step_mm`` from ``s_ref`` back along the channel: advance ``s_ref - k step`` for
    ``k = 0 .. n-1``. Without arguments: the measured path's step and extent when the channel has
    one, else ``DEFAULT_STEP_MM`` (1 mm, the paper's) over ``DEFAULT_SPAN_MM`` (60 mm, the ring).
    Advances below 0 are dropped.
    """
    s_ref = m_to_mm(channel.s_ref_m)
    measured = getattr(channel, "measured_path_m", None)
    m_step = getattr(channel, "measured_step_m", None)
    if step_mm is None:
        step_mm = m_to_mm(m_step) if m_step else DEFAULT_STEP_MM
    if span_mm is None:
        if measured is not None and m_step:
            span_mm = (len(measured) - 1) * m_to_mm(m_step)
        else:
            span_mm = DEFAULT_SPAN_MM
    n = math.floor(min(span_mm, s_ref) / step_mm + 1e-9) + 1
    adv = s_ref - step_mm * np.arange(n)
    return np.sort(adv[adv >= 0.0])


def _motion(ck: _Checker, channel, preset: str) -> tuple[Motion, np.ndarray]:
    sec = ck.section("motion")
    v = {k: ck.value("motion", k, sec=sec) for k in SCHEMA["motion"]}
    length_mm = m_to_mm(channel.centreline.length_m)
    if v["advances_mm"] is not None:
        adv = ck.numbers("motion.advances_mm", v["advances_mm"])  # wins over step_mm/span_mm
    else:
        adv = default_advances_mm(channel, v["step_mm"], v["span_mm"])
    if adv.size == 0:
        raise ck.fail("motion.advances_mm", "no advances", "give at least one advance")
    if np.any(adv > length_mm) or np.any(adv < 0):
        raise ck.fail(
            "motion.advances_mm",
            f"values outside the channel [0, {length_mm:.2f}] mm",
            "advances are centreline arc lengths of the source centre inside the channel",
        )
    if v["kind"] in ("constant", "stepwise") and np.any(np.diff(adv) < 0) and not v["backward"]:
        raise ck.fail(
            "motion.advances_mm",
            "not ascending",
            "list forward advances in increasing order (or set motion.backward = true)",
        )
    speed = v["speed_mm_s"]
    from ringqa.simulation.instruments import INPUT_SPEED_M_S

    speed_m_s = mm_to_m(speed) if speed is not None else INPUT_SPEED_M_S.get(preset, 0.5)
    motion = Motion(
        kind=v["kind"],
        advances_m=tuple(float(a) for a in mm_to_m(adv)),
        speed_m_s=float(speed_m_s),
        start_m=None if v["start_mm"] is None else mm_to_m(v["start_mm"]),
        dwell_s=float(v["dwell_s"]),
        backward=bool(v["backward"]),
    )
    return motion, adv


def _solver(ck: _Checker) -> SolverSettings:
    sec = ck.section("solver")
    v = {k: ck.value("solver", k, sec=sec) for k in SCHEMA["solver"]}
    settings = SolverSettings(
        kind=v["kind"],
        integrator=v["integrator"],
        increment_m=mm_to_m(v["increment_mm"]),
        time_step_s=float(v["time_step_s"]),
        tol=float(v["tol"]),
        max_iter=int(v["max_iter"]),
        stabilisation=float(v["stabilisation"]),
        jam_force_n=float(v["jam_force_n"]),
        jam_length_m=mm_to_m(v["jam_length_mm"]),
    )
    return _extra_in(ck, "solver", settings)


# ------------------------------------------------------------------------------------------------
# public API
# ------------------------------------------------------------------------------------------------
def load_scene(
    path_or_dict: str | Path | Mapping[str, Any],
    overrides: Mapping[str, Any] | None = None,
    name: str | None = None,
) -> Scene:
    """Load and validate a scene (TOML file or dict in user units) into an SI :class:`Scene`.

    Parameters
    ----------
    path_or_dict : str, Path or mapping
        A scene TOML file, a shipped scene name (``"ring26-flexitron"`` from ``data/scenes``), or
        the same content as a dict.
    overrides : mapping of dotted key -> value, optional
        ``{"solver.increment_mm": 0.5}``; string values are parsed as TOML values.
    name : str, optional
        Scene name; default the file's ``name`` key, the file stem, or ``"scene"``.

    Returns
    -------
    Scene
        With ``scene.source`` = the validated user-level dict (defaults filled in), which
        :func:`scene_to_dict` writes back.

    Raises
    ------
    SceneError
        Naming the file and dotted key and how to fix it.
    """
    if isinstance(path_or_dict, Mapping):
        data, origin, stem = dict(path_or_dict), "", None
    else:
        path = _resolve_scene_path(path_or_dict)
        data, origin, stem = read_scene_dict(path), f"{path}: ", path.stem
    data = apply_overrides(data, overrides, origin)
    return _scene_from_data(data, origin, name or None, stem)


def _scene_from_data(data: dict, origin: str, name: str | None, stem: str | None, channel=None):
    ck = _Checker(data, origin)
    unknown = sorted(set(data) - set(SCHEMA) - set(SCHEMA[""]))
    if unknown:
        raise ck.fail(
            unknown[0],
            "unknown top-level key or table",
            f"allowed: {', '.join([*SCHEMA[''], *[s for s in SCHEMA if s]])}",
        )
    for sec_name, keys in SCHEMA.items():  # every key's name, type and range before any work
        sec = ck.section(sec_name) if sec_name else data
        for key in keys:
            if key in sec:
                ck.value(sec_name, key, sec=sec if sec_name else None)
    scene_name = name or ck.value("", "name") or stem or "scene"
    preset = ck.value("instrument", "preset")
    if channel is None:
        channel = build_channel(ck)
    motion, _ = _motion(ck, channel, preset)
    instrument = _instrument(ck, float(np.max(motion.advances_m)), preset)
    channel_spec = copy.deepcopy(data.get("channel", {}))
    app = channel_spec.get("applicator")
    if app is not None and origin and ("/" in str(app) or str(app).endswith(".json")):
        cand = Path(origin.rstrip(": ")).parent / str(app)
        if cand.exists():  # keep the scene usable from another folder
            channel_spec["applicator"] = str(cand.resolve())
    scene = Scene(
        name=str(scene_name),
        channel=channel,
        instrument=instrument,
        effects=_effects(ck),
        contact=_contact(ck, preset),
        motion=motion,
        solver=_solver(ck),
        outputs=Outputs(trajectory=ck.value("outputs", "trajectory")),
        source={"channel": channel_spec, "description": ck.value("", "description")},
    )
    return replace(scene, source=scene_to_dict(scene))


def _resolve_scene_path(ref: str | Path) -> Path:
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


def _channel_spec(scene: Scene) -> dict:
    spec = scene.source.get("channel") if isinstance(scene.source, Mapping) else None
    if spec:
        return copy.deepcopy(dict(spec))
    # programmatic channel: write it inline (centreline points and the lumen)
    ch = scene.channel
    cl = ch.centreline
    pts = getattr(cl, "points_m", None)
    if pts is None:
        pts = cl.position(np.linspace(0.0, cl.length_m, _count(m_to_mm(cl.length_m))))
    spec: dict[str, Any] = {
        "kind": "points",
        "channel": ch.name,
        "centreline_mm": np.round(m_to_mm(np.asarray(pts)), 6).tolist(),
        "s_ref_mm": m_to_mm(ch.s_ref_m),
    }
    spec.update(_lumen_spec(ch.lumen))
    if ch.measured_path_m is not None and ch.measured_step_m:
        spec["measured_path_mm"] = np.round(m_to_mm(ch.measured_path_m), 6).tolist()
        spec["measured_step_mm"] = m_to_mm(ch.measured_step_m)
    return spec


def _lumen_spec(lumen) -> dict:
    seg_s, seg_rb, seg_ra, seg_flat = (np.asarray(a, dtype=float) for a in lumen.kernel_arrays())
    radii = {"r_b_mm": m_to_mm(float(seg_rb[0])), "r_a_mm": m_to_mm(float(seg_ra[0]))}
    same_r = np.all(seg_rb == seg_rb[0]) and np.all(seg_ra == seg_ra[0])
    finite = np.isfinite(seg_flat)
    if same_r and not finite.any():
        return {"lumen": "circular", **radii}
    if same_r and finite.sum() == 1 and len(seg_flat) <= 3:
        i = int(np.flatnonzero(finite)[0])
        spec = {"lumen": "u", **radii, "flat_mm": m_to_mm(float(seg_flat[i]))}
        if np.isfinite(seg_s[i]):
            spec["u_start_mm"] = m_to_mm(float(seg_s[i]))
        if np.isfinite(seg_s[i + 1]):
            spec["u_end_mm"] = m_to_mm(float(seg_s[i + 1]))
        return spec
    spec = {
        "lumen": "stepped",
        "s_breaks_mm": m_to_mm(seg_s[1:-1]).tolist(),
        "r_b_mm": m_to_mm(seg_rb).tolist(),
        "r_a_mm": m_to_mm(seg_ra).tolist(),
    }
    if finite.any():
        spec["flat_mm"] = np.where(finite, m_to_mm(np.where(finite, seg_flat, 0.0)), 0.0).tolist()
    return spec


def scene_to_dict(scene: Scene) -> dict:
    """The scene in user units as a TOML-able dict that :func:`load_scene` reads back unchanged.

    The channel is written as it was given (applicator name or analytic spec) when the scene came
    from a file, else inline (centreline points and lumen). The instrument is written as its
    sections (so a re-discretised or trimmed preset round-trips exactly) together with its preset
    name for the contact defaults.
    """
    inst = scene.instrument
    preset = inst.name if inst.name in CABLE_PRESETS else None
    out: dict[str, Any] = {"name": scene.name}
    desc = scene.source.get("description") if isinstance(scene.source, Mapping) else None
    if desc:
        out["description"] = desc
    out["channel"] = _channel_spec(scene)
    instrument: dict[str, Any] = {}
    if preset:
        instrument["preset"] = preset
    instrument["centre_from_tip_mm"] = m_to_mm(inst.centre_from_tip_m)
    instrument["sections"] = [
        {
            "name": s.name,
            "length_mm": m_to_mm(s.length_m),
            "r_o_mm": m_to_mm(s.r_o_m),
            "ei_nm2": s.ei_nm2,
            "gj_nm2": s.gj_nm2,
            "mass_per_length_kg_m": s.mass_per_length_kg_m,
            "element_length_mm": m_to_mm(s.element_length_m),
            "rigid": bool(s.rigid),
        }
        for s in inst.sections
    ]
    out["instrument"] = instrument
    e = scene.effects
    effects: dict[str, Any] = {
        "torsion": e.torsion,
        "contact": e.contact,
        "friction": e.friction,
        "wall_damping": e.wall_damping,
        "inertia": e.inertia,
        "gravity": e.gravity_m_s2 is not None,
    }
    if e.gravity_m_s2 is not None:
        effects["gravity_m_s2"] = [float(g) for g in e.gravity_m_s2]
    out["effects"] = effects
    c = scene.contact
    contact: dict[str, Any] = {
        "stiffness_n_m": c.stiffness_n_m,
        "damping_ns_m": c.damping_ns_m,
        "mu_s": c.mu_s,
        "mu_k": c.mu_k,
        "v_brk_mm_s": m_to_mm(c.v_brk_m_s),
    }
    if c.transition_m is not None:
        contact["transition_mm"] = m_to_mm(c.transition_m)
    contact.update(_extra_out(c, "contact"))
    out["contact"] = contact
    m = scene.motion
    motion: dict[str, Any] = {
        "kind": m.kind,
        "advances_mm": [m_to_mm(a) for a in m.advances_m],
        "speed_mm_s": m_to_mm(m.speed_m_s),
        "dwell_s": m.dwell_s,
        "backward": m.backward,
    }
    if m.start_m is not None:
        motion["start_mm"] = m_to_mm(m.start_m)
    out["motion"] = motion
    s = scene.solver
    out["solver"] = {
        "kind": s.kind,
        "integrator": s.integrator,
        "increment_mm": m_to_mm(s.increment_m),
        "time_step_s": s.time_step_s,
        "tol": s.tol,
        "max_iter": int(s.max_iter),
        "stabilisation": s.stabilisation,
        "jam_force_n": s.jam_force_n,
        "jam_length_mm": m_to_mm(s.jam_length_m),
        **_extra_out(s, "solver"),
    }
    out["outputs"] = {"trajectory": bool(scene.outputs.trajectory)}
    return _plain(out)


def _plain(obj):
    """Python floats/ints/lists only (TOML-able, JSON-able)."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | np.ndarray):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating | float):
        return float(f"{float(obj):.12g}")  # 12 digits: drops unit-conversion round-off
    return obj


def scene_with_overrides(scene: Scene, overrides: Mapping[str, Any]) -> Scene:
    """A new scene with dotted-key overrides (user units) applied to ``scene``'s settings.

    ``discretisation.element_length_mm`` re-discretises the instrument's sections; the channel
    object is kept unless a ``channel.*`` key is overridden; ``motion.step_mm``/``span_mm``
    replace the scene's advances.
    """
    over = dict(overrides)
    data = scene_to_dict(scene)
    if any(k in over for k in ("motion.step_mm", "motion.span_mm")):
        data["motion"].pop("advances_mm", None)
    if "instrument.preset" in over or "instrument.real_mass" in over:
        data["instrument"].pop("sections", None)
        data["instrument"].pop("centre_from_tip_mm", None)
        if "instrument.preset" in over:
            data.pop("contact", None)
    data = apply_overrides(data, over)
    keep = None if any(k.startswith("channel.") or k == "channel" for k in over) else scene.channel
    return _scene_from_data(data, "", scene.name, None, channel=keep)


def scene_for_channel(channel, cable: str = "flexitron", **overrides) -> Scene:
    """A scene for a channel object (the pipeline's entry), defaults from the cable preset.

    Parameters
    ----------
    channel : ringqa.geometry.Channel
        Used as is (its centreline is not re-fitted); default dwell advances follow its measured
        path (or every 1 mm over 60 mm back from ``s_ref``).
    cable : str
        Instrument preset name (``"flexitron"``).
    **overrides
        Section tables in user units, ``solver={"increment_mm": 0.5}``, or single keys with the
        dot written as a double underscore, ``solver__increment_mm=0.5``.

    Returns
    -------
    Scene
    """
    if cable not in CABLE_PRESETS:
        raise SceneError(
            f"cable = {cable!r}: unknown preset (choose one of {', '.join(sorted(CABLE_PRESETS))})"
        )
    data: dict[str, Any] = {"instrument": {"preset": cable}}
    flat: dict[str, Any] = {}
    for key, val in overrides.items():
        if isinstance(val, Mapping):
            data.setdefault(key, {}).update(val)
        else:
            flat[key.replace("__", ".")] = val
    data = apply_overrides(data, flat)
    scene = _scene_from_data(data, "", f"{channel.name}-{cable}", None, channel=channel)
    return scene
