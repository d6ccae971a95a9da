"""Instrument presets: the Flexitron and microSelectron source cables, the paper's catheter.

The Flexitron cable and the catheter come from Straathof et al., Med Phys 2024, Table 1 (the
paper's SPACAR parameters), with the source-capsule geometry from the egs_brachy Flexisource model
(``shared/reference/domain.md``). The microSelectron mHDR-v2 cable has the mHDR-v2 capsule and
cable geometry of the egs_brachy model, but its bending and torsional stiffness and its wall
contact are NOT published: they are borrowed from the Flexitron's thick section and contact
measurements and said so (:data:`PRESET_SOURCES`). SI units throughout.

``CABLE_PRESETS[name]`` is an :class:`~ringqa.simulation.scene.Instrument` (sections from the tip
back); ``CONTACT_PRESETS[name]`` the wall/friction parameters measured for that instrument;
``INPUT_SPEED_M_S[name]`` the paper's input speed. :func:`cable_preset` returns a copy with the
element lengths and modelled length changed (what the scene file and the accuracy study vary).

Mass per length
---------------
The paper scaled the mass per length UP to lower the elements' eigenfrequencies and allow larger
explicit time steps: 0.04 kg/m in its rigid-link model (the model ringqa uses; 0.1 kg/m in its
flexible-beam model) for the source cable, 1 kg/m for the catheter. The presets carry the paper's
rigid-link value so the dynamic scene reproduces the paper's setting. The real values are listed
in :data:`REAL_MASS_PER_LENGTH_KG_M` (estimates from the geometry: steel 7.9 g/cm^3, iridium
22.56 g/cm^3): about 1.5 g/m for the 0.50 mm thin cable, 4.5 g/m for the 0.85 mm thick cable,
7.6 g/m for the capsule (steel shell plus 3.5 x 0.6 mm Ir core over 4.6 mm). Use
:func:`cable_preset` with ``real_mass=True`` to simulate with them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

from ringqa.errors import SceneError
from ringqa.simulation.scene import CableSection, ContactParams, Instrument
from ringqa.units import m_to_mm

# ---- Flexitron source cable (Table 1, "BT source positioning"; domain.md) ----------------------
FLEXITRON_CAPSULE_LENGTH_M = 4.6e-3  # capsule length (egs_brachy Flexisource)
FLEXITRON_CENTRE_FROM_TIP_M = 2.4e-3  # tip to centre of activity
FLEXITRON_THIN_LENGTH_M = 0.105  # thin section next to the source (Table 1, L thin)
FLEXITRON_THICK_LENGTH_M = 0.616  # thick section (Table 1); the engine models what it needs
PAPER_MASS_RIGID_LINK_KG_M = 0.04  # Table 1 m/l for the rigid-link model (scaled up)

# ---- microSelectron mHDR-v2 source cable (egs_brachy geometry; domain.md) ---------------------
MHDR_V2_CAPSULE_LENGTH_M = 4.5e-3  # capsule length (egs_brachy mHDR-v2)
MHDR_V2_CENTRE_FROM_TIP_M = 2.0e-3  # tip to centre of activity
MHDR_V2_CAPSULE_R_M = 0.45e-3  # capsule outer diameter 0.90 mm
MHDR_V2_CABLE_R_M = 0.35e-3  # cable diameter 0.70 mm
MHDR_V2_CABLE_LENGTH_M = 0.721  # as the Flexitron thin + thick; the engine models what it needs

_STEEL_KG_M3 = 7900.0
_IRIDIUM_KG_M3 = 22560.0


def _rod_mass_per_length(radius_m: float, density: float) -> float:
    return density * math.pi * radius_m**2


def _capsule_mass_per_length(
    r_o_m: float = 0.425e-3,
    length_m: float = FLEXITRON_CAPSULE_LENGTH_M,
    core_r_m: float = 0.30e-3,
    core_length_m: float = 3.5e-3,
) -> float:
    outer = math.pi * r_o_m**2 * length_m
    core = math.pi * core_r_m**2 * core_length_m
    mass = _STEEL_KG_M3 * (outer - core) + _IRIDIUM_KG_M3 * core
    return mass / length_m


#: Real (unscaled) mass per length, kg/m, per preset and section name (estimates, see module doc).
REAL_MASS_PER_LENGTH_KG_M: dict[str, dict[str, float]] = {
    "flexitron": {
        "capsule": _capsule_mass_per_length(),  # ~7.6e-3
        "thin": _rod_mass_per_length(0.25e-3, _STEEL_KG_M3),  # ~1.55e-3
        "thick": _rod_mass_per_length(0.425e-3, _STEEL_KG_M3),  # ~4.48e-3
    },
    "microselectron": {
        "capsule": _capsule_mass_per_length(
            MHDR_V2_CAPSULE_R_M, MHDR_V2_CAPSULE_LENGTH_M, 0.325e-3, 3.6e-3
        ),  # ~9.3e-3
        "cable": _rod_mass_per_length(MHDR_V2_CABLE_R_M, _STEEL_KG_M3),  # ~3.0e-3
    },
    # ProGuide 6F: polymer tube (PEEK-like, ~1.3 g/cm^3) around a steel obturator (~0.8 mm):
    "catheter": {
        "catheter": 1.3e3 * math.pi * (0.99e-3**2 - 0.4e-3**2) + 7.9e3 * math.pi * 0.4e-3**2
    },
}

FLEXITRON = Instrument(
    name="flexitron",
    sections=(
        CableSection(
            name="capsule",
            length_m=FLEXITRON_CAPSULE_LENGTH_M,
            r_o_m=0.425e-3,
            ei_nm2=1.8e-4,  # rigid: one link; stiffness only used at its joint to the thin cable
            gj_nm2=1.4e-4,
            mass_per_length_kg_m=PAPER_MASS_RIGID_LINK_KG_M,
            element_length_m=FLEXITRON_CAPSULE_LENGTH_M,
            rigid=True,
        ),
        CableSection(
            name="thin",
            length_m=FLEXITRON_THIN_LENGTH_M,
            r_o_m=0.25e-3,
            ei_nm2=5.2e-5,
            gj_nm2=4.0e-5,
            mass_per_length_kg_m=PAPER_MASS_RIGID_LINK_KG_M,
            element_length_m=3.0e-3,
        ),
        CableSection(
            name="thick",
            length_m=FLEXITRON_THICK_LENGTH_M,
            r_o_m=0.425e-3,
            ei_nm2=1.8e-4,
            gj_nm2=1.4e-4,
            mass_per_length_kg_m=PAPER_MASS_RIGID_LINK_KG_M,
            element_length_m=10.0e-3,
        ),
    ),
    centre_from_tip_m=FLEXITRON_CENTRE_FROM_TIP_M,
    afterloader="flexitron",
)

# ---- microSelectron mHDR-v2 cable: geometry published, mechanics borrowed ----------------------
MICROSELECTRON = Instrument(
    name="microselectron",
    sections=(
        CableSection(
            name="capsule",
            length_m=MHDR_V2_CAPSULE_LENGTH_M,
            r_o_m=MHDR_V2_CAPSULE_R_M,
            ei_nm2=1.8e-4,  # rigid: one link; stiffness only used at its joint to the cable
            gj_nm2=1.4e-4,
            mass_per_length_kg_m=PAPER_MASS_RIGID_LINK_KG_M,
            element_length_m=MHDR_V2_CAPSULE_LENGTH_M,
            rigid=True,
        ),
        CableSection(
            name="cable",
            length_m=MHDR_V2_CABLE_LENGTH_M,
            r_o_m=MHDR_V2_CABLE_R_M,
            ei_nm2=1.8e-4,  # ASSUMED: the Flexitron thick section's (Table 1); not published
            gj_nm2=1.4e-4,  # ASSUMED: likewise
            mass_per_length_kg_m=PAPER_MASS_RIGID_LINK_KG_M,
            element_length_m=3.0e-3,
        ),
    ),
    centre_from_tip_m=MHDR_V2_CENTRE_FROM_TIP_M,
    afterloader="microselectron",
)

# ---- ProGuide 6F catheter with obturator (Table 1, "Needle insertion") -------------------------
# Every value checked against Table 1's needle column (Straathof et al. 2024) for issue 14.
CATHETER = Instrument(
    name="catheter",
    sections=(
        CableSection(
            name="catheter",
            length_m=0.12,  # Table 1 L = 0.12 m: the free length between clamp and tip (sec. 2.4)
            r_o_m=0.99e-3,  # Table 1 r_o = 0.99 mm
            ei_nm2=1.2e-2,  # Table 1 EI = 1.2e-2 N m^2
            gj_nm2=9.6e-3,  # Table 1 GJ = 9.6e-3 N m^2
            mass_per_length_kg_m=1.0,  # Table 1 m/l = 1 kg/m (scaled up, as for the cable)
            element_length_m=3.3e-3,  # Table 1 l_rig = 3.3 mm
        ),
    ),
    centre_from_tip_m=0.0,  # no source: the reported "source" point is the tip
    afterloader="",
)

#: Instrument presets by name.
CABLE_PRESETS: dict[str, Instrument] = {
    "flexitron": FLEXITRON,
    "microselectron": MICROSELECTRON,
    "catheter": CATHETER,
}

#: Where each preset's numbers come from, in words for reports (``"assumed"`` where borrowed).
PRESET_SOURCES: dict[str, str] = {
    "flexitron": (
        "Flexitron source cable: stiffness, friction and wall contact from Straathof et al. 2024, "
        "Table 1; capsule geometry from the egs_brachy Flexisource model"
    ),
    "microselectron": (
        "microSelectron mHDR-v2 source cable: capsule (0.90 x 4.5 mm, centre 2.0 mm from the "
        "tip) and cable diameter (0.70 mm) from the egs_brachy mHDR-v2 model; bending and "
        "torsional stiffness, friction and wall contact ASSUMED (borrowed from the Flexitron "
        "cable's thick section and contact measurements, Straathof et al. 2024, Table 1: no "
        "published values for this cable)"
    ),
    "catheter": "ProGuide 6F catheter with obturator: Straathof et al. 2024, Table 1",
}

#: Presets whose mechanics are borrowed from another cable (the report says so).
BORROWED_MECHANICS: frozenset[str] = frozenset({"microselectron"})

#: Contact and friction parameters measured with each instrument (Table 1).
CONTACT_PRESETS: dict[str, ContactParams] = {
    "flexitron": ContactParams(
        stiffness_n_m=1.0e5, damping_ns_m=10.0, mu_s=0.25, mu_k=0.20, v_brk_m_s=1.0e-3
    ),
    # ASSUMED: the Flexitron cable's measurements (no published values for the microSelectron)
    "microselectron": ContactParams(
        stiffness_n_m=1.0e5, damping_ns_m=10.0, mu_s=0.25, mu_k=0.20, v_brk_m_s=1.0e-3
    ),
    # Table 1 needle column: k = 1e6 N/m, c_w = 10 N s/m, mu_s = 0.094, mu_k = 0.074,
    # v_brk = 0.001 m/s (r_a, r_b belong to the channel: ringqa.geometry.s_channel)
    "catheter": ContactParams(
        stiffness_n_m=1.0e6, damping_ns_m=10.0, mu_s=0.094, mu_k=0.074, v_brk_m_s=1.0e-3
    ),
}

#: The paper's input speed per preset (m/s): 0.5 m/s for the source cable, 0.1 m/s for the catheter.
INPUT_SPEED_M_S: dict[str, float] = {"flexitron": 0.5, "microselectron": 0.5, "catheter": 0.1}


def cable_preset(
    name: str,
    element_length_m: float | Mapping[str, float] | None = None,
    length_m: float | None = None,
    real_mass: bool = False,
) -> Instrument:
    """A preset instrument, optionally re-discretised, trimmed and with real masses.

    Parameters
    ----------
    name : str
        Preset name, one of ``CABLE_PRESETS`` (``"flexitron"``, ``"catheter"``).
    element_length_m : float or mapping of section name -> float, optional
        Link length (m) for every flexible section (a number) or per section name
        (e.g. ``{"thin": 3e-3, "thick": 10e-3}``); rigid sections stay one link.
    length_m : float, optional
        Total modelled length (m): the LAST (most proximal) section is shortened or lengthened so
        the instrument has this length (it must keep a positive length).
    real_mass : bool
        Use :data:`REAL_MASS_PER_LENGTH_KG_M` instead of the paper's scaled-up masses.

    Returns
    -------
    Instrument

    Raises
    ------
    SceneError
        Unknown preset or section name, non-positive lengths, or a length too short to hold the
        distal sections.
    """
    if name not in CABLE_PRESETS:
        raise SceneError(
            f"instrument.preset = {name!r}: unknown preset "
            f"(choose one of {', '.join(sorted(CABLE_PRESETS))})"
        )
    inst = CABLE_PRESETS[name]
    sections = list(inst.sections)
    if element_length_m is not None:
        if isinstance(element_length_m, Mapping):
            known = {s.name for s in sections}
            unknown = sorted(set(element_length_m) - known)
            if unknown:
                raise SceneError(
                    f"discretisation.element_length_mm: unknown section(s) {unknown} for the "
                    f"{name!r} instrument (its sections are {', '.join(s.name for s in sections)})"
                )
            per = dict(element_length_m)
        else:
            per = {s.name: float(element_length_m) for s in sections if not s.rigid}
        for key, val in per.items():
            if not (math.isfinite(float(val)) and float(val) > 0):
                raise SceneError(
                    f"discretisation.element_length_mm.{key} = {val}: must be a positive length"
                )
        sections = [
            replace(s, element_length_m=float(per[s.name])) if s.name in per and not s.rigid else s
            for s in sections
        ]
    if real_mass:
        masses = REAL_MASS_PER_LENGTH_KG_M[name]
        sections = [replace(s, mass_per_length_kg_m=masses[s.name]) for s in sections]
    if length_m is not None:
        distal = sum(s.length_m for s in sections[:-1])
        last = float(length_m) - distal
        if not (math.isfinite(last) and last > 0):
            raise SceneError(
                f"instrument.length_mm = {m_to_mm(float(length_m)):g}: must exceed the distal "
                f"sections' length {m_to_mm(distal):g} mm of the {name!r} instrument"
            )
        sections[-1] = replace(sections[-1], length_m=last)
    return replace(inst, sections=tuple(sections))
