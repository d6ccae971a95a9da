"""Write a :class:`Scene` back as a user-unit dict (TOML-able) that ``load_scene`` reads unchanged.

The channel as it was given (or inline points and lumen for a programmatic channel), the
instrument as its sections, every other section with all its keys, values rounded to 12 digits.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

import numpy as np

from ringqa.simulation.instruments import CABLE_PRESETS
from ringqa.simulation.scene import Scene
from ringqa.simulation.scenefile.channel import _count
from ringqa.simulation.scenefile.check import EXTRA_FIELDS
from ringqa.units import m_to_mm


def _extra_out(obj, section: str) -> dict:
    out = {}
    for key, (fname, unit) in EXTRA_FIELDS[section].items():
        val = getattr(obj, fname, None)
        if val is not None:
            out[key] = bool(val) if unit == "bool" else (m_to_mm(val) if unit == "mm" else val)
    return out


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
