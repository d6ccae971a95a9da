"""Write a :class:`Scene` back as a user-unit dict (TOML-able) that ``load_scene`` reads unchanged.

The channel as the scene file gave it (kept in ``scene.channel_spec`` while the channel is the one
it built) or inline points and lumen, the instrument as its sections, every other section with all
its keys (converted with the keys' own conversions), values rounded to 12 digits.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ringqa.simulation.instruments import CABLE_PRESETS
from ringqa.simulation.scene import Scene
from ringqa.simulation.scene_keys import section_keys
from ringqa.simulation.scenefile.channel import point_count
from ringqa.simulation.scenefile.read import plain_copy
from ringqa.units import m_to_mm


def channel_spec(scene: Scene) -> dict:
    """The ``[channel]`` table: as the file gave it, or inline points and the lumen."""
    if scene.channel_spec is not None:
        return plain_copy(dict(scene.channel_spec.spec))
    # a channel given as an object: write it inline (centreline points and the lumen)
    ch = scene.channel
    cl = ch.centreline
    pts = getattr(cl, "points_m", None)
    if pts is None:
        pts = cl.position(np.linspace(0.0, cl.length_m, point_count(m_to_mm(cl.length_m))))
    spec: dict[str, Any] = {
        "kind": "points",
        "channel": ch.name,
        "centreline_mm": np.round(m_to_mm(np.asarray(pts)), 6).tolist(),
        "s_ref_mm": m_to_mm(ch.s_ref_m),
    }
    spec.update(lumen_spec(ch.lumen))
    if ch.measured_path_m is not None and ch.measured_step_m:
        spec["measured_path_mm"] = np.round(m_to_mm(ch.measured_path_m), 6).tolist()
        spec["measured_step_mm"] = m_to_mm(ch.measured_step_m)
    return spec


def lumen_spec(lumen) -> dict:
    """A lumen as ``[channel]`` lumen keys (the one lumen vocabulary of
    :mod:`ringqa.geometry.lumen_spec`; its ``kind`` is the key ``lumen``, its ``source``
    ``lumen_source``)."""
    from ringqa.geometry.lumen_spec import lumen_to_spec

    spec = lumen_to_spec(lumen)
    out = {"lumen": spec.pop("kind")}
    if "source" in spec:
        spec["lumen_source"] = spec.pop("source")
    if spec.get("flat_towards") == "bend_outside":
        del spec["flat_towards"]
    out.update(spec)
    return out


def section_dict(section: str, obj) -> dict:
    """Every field of a section dataclass as its key in user units (None fields left out)."""
    out = {}
    for k in section_keys(section):
        if not k.field:
            continue
        value = getattr(obj, k.field)
        if value is not None:
            out[k.name] = k.from_si(value)
    return out


def scene_to_dict(scene: Scene) -> dict:
    """The scene in user units as a TOML-able dict that :func:`load_scene` reads back unchanged.

    The channel is written as it was given (applicator name or analytic spec) when the scene came
    from a file and still has that channel, else inline (centreline points and lumen). The
    instrument is written as its sections (so a re-discretised or trimmed preset round-trips
    exactly) together with its preset name for the contact defaults.
    """
    inst = scene.instrument
    preset = inst.name if inst.name in CABLE_PRESETS else None
    out: dict[str, Any] = {"name": scene.name}
    if scene.description:
        out["description"] = scene.description
    out["channel"] = channel_spec(scene)
    instrument: dict[str, Any] = {}
    if preset:
        instrument["preset"] = preset
    instrument.update(section_dict("instrument", inst))
    instrument["sections"] = [section_dict("section", s) for s in inst.sections]
    out["instrument"] = instrument
    effects = section_dict("effects", scene.effects)
    effects.pop("gravity_m_s2", None)
    effects["gravity"] = scene.effects.gravity_m_s2 is not None
    if scene.effects.gravity_m_s2 is not None:
        effects["gravity_m_s2"] = [float(g) for g in scene.effects.gravity_m_s2]
    out["effects"] = effects
    out["contact"] = section_dict("contact", scene.contact)
    out["motion"] = section_dict("motion", scene.motion)
    out["solver"] = section_dict("solver", scene.solver)
    out["outputs"] = section_dict("outputs", scene.outputs)
    if scene.model != type(scene.model)():  # written only when not the default (rigid)
        out["model"] = section_dict("model", scene.model)
    return plain(out)


def plain(obj):
    """Python floats/ints/lists only (TOML-able, JSON-able)."""
    if isinstance(obj, dict):
        return {k: plain(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple | np.ndarray):
        return [plain(v) for v in obj]
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating | float):
        return float(f"{float(obj):.12g}")  # 12 digits: drops unit-conversion round-off
    return obj
