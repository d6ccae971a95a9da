"""The scene file's key schema and the checker that validates values against it.

:data:`SCHEMA` gives every key of every section its accepted types, default and allowed values
(:data:`EXTRA_FIELDS`: keys that exist only when the engine defines the field;
:data:`SECTION_KEYS`: the keys of a custom instrument section). :class:`_Checker` reads keys
through the schema and builds the errors that name the file, the dotted key and the fix.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ringqa.errors import SceneError
from ringqa.simulation.instruments import CABLE_PRESETS
from ringqa.simulation.scene import FRICTION_LAWS, INTEGRATORS, MOTION_KINDS, SOLVER_KINDS

CHANNEL_KINDS = ("applicator", "straight", "arc", "helix", "s-curve", "points")
LUMEN_KINDS = ("circular", "u", "stepped")
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


class _Checker:
    """Reads a scene dict's keys through :data:`SCHEMA`; ``origin`` prefixes every error."""

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
