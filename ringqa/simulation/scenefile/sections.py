"""Build a scene's instrument, effects, contact, motion, solver and outputs from their tables.

One builder a section, each reading its keys through the :class:`~.check.Checker` and converting
them to SI with the keys' own conversions (:mod:`ringqa.simulation.scene_keys`); the dataclasses
validate the result once more (:mod:`ringqa.simulation.scene`). :func:`default_advances_mm` gives
the dwell advances of a scene that lists none.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ringqa.simulation.instruments import (
    CABLE_PRESETS,
    CONTACT_PRESETS,
    INPUT_SPEED_M_S,
    cable_preset,
)
from ringqa.simulation.scene import (
    CableSection,
    ContactParams,
    Effects,
    Instrument,
    ModelSettings,
    Motion,
    Outputs,
    SolverSettings,
)
from ringqa.simulation.scene_keys import NUM, section_keys
from ringqa.simulation.scenefile.check import Checker
from ringqa.units import m_to_mm, mm_to_m

STANDARD_GRAVITY_M_S2 = 9.80665
#: Default gravity (m/s^2): ringqa's applicator frames are DICOM patient coordinates (x to the
#: patient's left, y posterior, z cranial) and the patient lies supine, so gravity points
#: posterior (+y).
DEFAULT_GRAVITY_M_S2 = (0.0, STANDARD_GRAVITY_M_S2, 0.0)
DEFAULT_STEP_MM = 1.0  # dwell spacing when the channel has no measured path (paper: 1 mm)
DEFAULT_SPAN_MM = 60.0  # length covered by default dwells without a measured path (ring: 60 mm)


def given_fields(ck: Checker, section: str, sec: dict) -> dict:
    """The SI values of the keys of ``section`` given in its table that set a dataclass field."""
    out = {}
    for k in section_keys(section):
        if k.field and k.name in sec:
            out[k.field] = k.to_si(ck.value(section, k.name, sec=sec))
    return out


def read_instrument(ck: Checker, preset: str) -> Instrument:
    """``[instrument]`` and ``[discretisation]``: a preset or custom instrument, re-discretised and
    lengthened as asked."""
    sec = ck.section("instrument")
    disc = ck.section("discretisation")
    elem = ck.value("discretisation", "element_length_mm", sec=disc)
    sections_in = ck.value("instrument", "sections", sec=sec)
    if sections_in is not None:
        inst = read_custom_instrument(ck, sec, sections_in)
    else:
        inst = cable_preset(preset, real_mass=ck.value("instrument", "real_mass", sec=sec))
        inst = replace(inst, **given_fields(ck, "instrument", sec))
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
                ck.check(f"discretisation.element_length_mm.{k}", v, NUM, "positive")
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


def read_custom_instrument(ck: Checker, sec: dict, sections_in: list) -> Instrument:
    """``[[instrument.sections]]`` tables, tip first, into an :class:`Instrument`."""
    secs = []
    names = [k.name for k in section_keys("section")]
    for i, raw in enumerate(sections_in):
        where = f"instrument.sections[{i}]"
        if not isinstance(raw, dict):
            raise ck.fail(where, "must be a table", "write [[instrument.sections]] tables")
        unknown = sorted(set(raw) - set(names))
        if unknown:
            raise ck.fail(f"{where}.{unknown[0]}", "unknown key", f"use {', '.join(names)}")
        vals = {}
        for k in section_keys("section"):
            if k.name not in raw:
                if k.default is None:
                    raise ck.fail(f"{where}.{k.name}", "missing", "every section needs it")
                continue
            vals[k.field] = k.to_si(ck.check(f"{where}.{k.name}", raw[k.name], k.types, k.check))
        secs.append(CableSection(**vals))
    if not secs:
        raise ck.fail("instrument.sections", "empty", "give at least one section")
    preset = sec.get("preset")
    cft = ck.value("instrument", "centre_from_tip_mm", sec=sec)
    return Instrument(
        name=str(preset) if preset else "custom",
        sections=tuple(secs),
        centre_from_tip_m=mm_to_m(cft if cft is not None else 0.0),
        afterloader=CABLE_PRESETS[preset].afterloader if preset in CABLE_PRESETS else "",
    )


def read_effects(ck: Checker) -> Effects:
    """``[effects]``."""
    sec = ck.section("effects")
    fields = given_fields(ck, "effects", sec)
    fields.pop("gravity_m_s2", None)
    gravity = None
    if ck.value("effects", "gravity", sec=sec):
        g = ck.value("effects", "gravity_m_s2", sec=sec)
        g = list(DEFAULT_GRAVITY_M_S2) if g is None else g
        gravity = tuple(float(x) for x in ck.numbers("effects.gravity_m_s2", g))
        if len(gravity) != 3:
            raise ck.fail("effects.gravity_m_s2", "needs 3 components", "write [gx, gy, gz]")
    return Effects(**fields, gravity_m_s2=gravity)


def read_contact(ck: Checker, preset: str) -> ContactParams:
    """``[contact]`` over the preset's contact parameters (the paper's Table 1)."""
    sec = ck.section("contact")
    base = CONTACT_PRESETS.get(preset, ContactParams())
    fields = given_fields(ck, "contact", sec)
    mu_s = fields.get("mu_s", base.mu_s)
    mu_k = fields.get("mu_k", base.mu_k)
    if mu_k > mu_s:
        raise ck.fail(
            "contact.mu_k",
            f"{mu_k} exceeds mu_s = {mu_s}",
            "the kinetic coefficient must not exceed the static (Stribeck peak) one",
        )
    return replace(base, **fields)


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


def read_motion(ck: Checker, channel, preset: str) -> Motion:
    """``[motion]``: the advances (given, or every step back from s_ref) and the input."""
    sec = ck.section("motion")
    v = {k.name: ck.value("motion", k.name, sec=sec) for k in section_keys("motion")}
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
    fields = given_fields(ck, "motion", sec)
    fields["advances_m"] = tuple(float(a) for a in mm_to_m(adv))
    fields.setdefault("speed_m_s", INPUT_SPEED_M_S.get(preset, 0.5))
    return Motion(**fields)


def read_solver(ck: Checker) -> SolverSettings:
    """``[solver]``."""
    return SolverSettings(**given_fields(ck, "solver", ck.section("solver")))


def read_outputs(ck: Checker) -> Outputs:
    """``[outputs]``."""
    return Outputs(**given_fields(ck, "outputs", ck.section("outputs")))


def read_model(ck: Checker) -> ModelSettings:
    """``[model]``."""
    return ModelSettings(**given_fields(ck, "model", ck.section("model")))


__all__ = [
    "DEFAULT_GRAVITY_M_S2",
    "DEFAULT_SPAN_MM",
    "DEFAULT_STEP_MM",
    "STANDARD_GRAVITY_M_S2",
    "default_advances_mm",
    "given_fields",
    "read_contact",
    "read_custom_instrument",
    "read_effects",
    "read_instrument",
    "read_model",
    "read_motion",
    "read_outputs",
    "read_solver",
]
