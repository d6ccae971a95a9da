"""Build a scene's instrument, effects, contact, motion and solver settings from their tables.

One builder a section (``[instrument]`` with ``[discretisation]``, ``[effects]``, ``[contact]``,
``[motion]``, ``[solver]``), each reading its keys through the checker and converting them to SI,
and :func:`default_advances_mm`, the dwell advances of a scene that lists none.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ringqa.simulation.instruments import CABLE_PRESETS, CONTACT_PRESETS, cable_preset
from ringqa.simulation.scene import (
    CableSection,
    ContactParams,
    Effects,
    Instrument,
    Motion,
    SolverSettings,
)
from ringqa.simulation.scenefile.check import _NUM, EXTRA_FIELDS, SCHEMA, SECTION_KEYS, _Checker
from ringqa.units import m_to_mm, mm_to_m

STANDARD_GRAVITY_M_S2 = 9.80665
DEFAULT_STEP_MM = 1.0  # dwell spacing when the channel has no measured path (paper: 1 mm)
DEFAULT_SPAN_MM = 60.0  # length covered by default dwells without a measured path (ring: 60 mm)


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
